//! The ballistometer on the STM32H743 (NUCLEO-H743ZI2). This file only wires the board: clocks,
//! pins and peripherals to the application of the `firmware` crate.
//!
//! | function | peripheral | pins (Nucleo header) |
//! |---|---|---|
//! | ADXL355 × 4 | SPI1 at 10 MHz, DMA1 ch0/1 | SCK PA5 (D13), MISO PA6 (D12), MOSI PB5 (D11); CS PD14 (D10), PD15 (D9), PF12 (D8), PF13 (D7) |
//! | SYNC line | GPIO | PE9 (D6) |
//! | LIS3DH | I2C1 at 400 kHz, DMA1 ch2/3 | SCL PB8 (D15), SDA PB9 (D14) |
//! | spacecraft link (RS-422 transceiver) | USART2 at 921 600 Bd, DMA1 ch4/5 | TX PD5, RX PD6 |
//!
//! Parts and arrangement: the built-in `tetra` board, or, built with
//! `BALLISTO_ARRANGEMENT=my-board.toml` (and optionally `BALLISTO_CALIBRATION=calibrated.toml`,
//! `BALLISTO_RATE_HZ`), the file's `[[sensor]]` tables: ADXL355 among the first four sensors
//! (one chip select each), LIS3DH at 0x18 or 0x19 by the sensor's place (see build.rs).
//!
//! Time base: embassy-time (TIM2, 1 MHz ticks). Log: defmt over RTT. Flash and run from this
//! directory with `cargo run --profile flight` (probe-rs runner, see `.cargo/config.toml`).
//!
//! Three priorities, as on the QEMU board: sampling, the application and the uplink on an
//! interrupt executor (UART4's vector, a peripheral this board does not use); below them on a
//! second (UART5's vector) the builder of the estimator's configurations (a part's exclusion
//! is precomputed there while the estimates go on) and the calibration storage task (a sector
//! erase blocks for up to seconds); and in thread mode, below everything, the identification
//! task (the window's sums and solve, and without a reference the search, which holds the
//! core for about a minute and must not hold up an exclusion).
//!
//! Calibration: the store in bank 2's first two sectors (`CAL_RANGE`), read at boot without
//! writing; its newest whole record replaces the built-in arrangement if it is for the same
//! channels (`calstore::select_at_boot`), and the choice is logged and reported in
//! housekeeping. The storage task then takes the store and commits what identification in
//! flight (TC[200,11]) asks.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(target_os = "none")]
mod board {
    use ballisto_fw::app::{
        app_task, uplink_task, App, Incoming, Links, Mode, Observations, COMMAND_QUEUE,
    };
    use ballisto_fw::boot::{count_boot, BootInfo, ResetCause};
    use ballisto_fw::calstore::{
        select_at_boot, CalibrationId, CalibrationStore, NotUsed, ReadOnly,
    };
    use ballisto_fw::config::AppConfig;
    use ballisto_fw::config::{PartKind, MAX_PARTS};
    use ballisto_fw::estimation::Builds;
    use ballisto_fw::identification::{Identification, Identifier};
    use ballisto_fw::sampler::{sampling_task, HealthBoard, PartBus, SampleSet, Sampler};
    use ballisto_fw::storage::{storage_task, CommitReplies, CommitRequests, StorageLinks};
    use ballisto_fw::supervisor::{supervisor_task, Liveness, Watchdog};
    use ballisto_fw::telemetry::Telemetry;
    use ballisto_fw::time::{Nanos, TimeBase};
    use defmt::{error, info};
    use defmt_rtt as _;
    use embassy_embedded_hal::adapter::BlockingAsync;
    use embassy_embedded_hal::shared_bus::asynch::{i2c::I2cDevice, spi::SpiDevice};
    use embassy_executor::{InterruptExecutor, Spawner};
    use embassy_stm32::flash::{Blocking, Flash};
    use embassy_stm32::gpio::{Level, Output, Speed};
    use embassy_stm32::i2c::{self, I2c};
    use embassy_stm32::interrupt;
    use embassy_stm32::interrupt::{InterruptExt, Priority};
    use embassy_stm32::mode::Async;
    use embassy_stm32::peripherals;
    use embassy_stm32::spi::{self, Spi};
    use embassy_stm32::time::Hertz;
    use embassy_stm32::usart::{self, RingBufferedUartRx, Uart, UartTx};
    use embassy_stm32::wdg::IndependentWatchdog;
    use embassy_stm32::{bind_interrupts, dma, pac, rcc};
    use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex as Cs;
    use embassy_sync::channel::Channel;
    use embassy_sync::mutex::Mutex;
    use embassy_sync::zerocopy_channel::{self, Channel as ZeroCopyChannel};
    use embassy_time::{Instant, Timer};
    use panic_probe as _;
    use static_cell::StaticCell;

    bind_interrupts!(struct Irqs {
        USART2 => usart::InterruptHandler<peripherals::USART2>;
        I2C1_EV => i2c::EventInterruptHandler<peripherals::I2C1>;
        I2C1_ER => i2c::ErrorInterruptHandler<peripherals::I2C1>;
        DMA1_STREAM0 => dma::InterruptHandler<peripherals::DMA1_CH0>;
        DMA1_STREAM1 => dma::InterruptHandler<peripherals::DMA1_CH1>;
        DMA1_STREAM2 => dma::InterruptHandler<peripherals::DMA1_CH2>;
        DMA1_STREAM3 => dma::InterruptHandler<peripherals::DMA1_CH3>;
        DMA1_STREAM4 => dma::InterruptHandler<peripherals::DMA1_CH4>;
        DMA1_STREAM5 => dma::InterruptHandler<peripherals::DMA1_CH5>;
    });

    type SpiBus = Spi<'static, Async, spi::mode::Master>;
    type I2cBus = I2c<'static, Async, i2c::mode::Master>;
    type Part = SpiDevice<'static, Cs, SpiBus, Output<'static>>;
    type I2cPart = I2cDevice<'static, Cs, I2cBus>;
    type Board = Sampler<Part, I2cPart, Output<'static>>;
    type Store = CalibrationStore<BlockingAsync<Flash<'static, Blocking>>>;

    /// Sampling, the application and the uplink: above everything else.
    static UPPER: InterruptExecutor = InterruptExecutor::new();
    /// The builder and the storage task: below the upper executor, above thread mode, where
    /// the identification task runs.
    static MIDDLE: InterruptExecutor = InterruptExecutor::new();

    #[interrupt]
    unsafe fn UART4() {
        // SAFETY: UART4's vector is the upper executor's alone (the peripheral is not used).
        unsafe { UPPER.on_interrupt() }
    }

    #[interrupt]
    unsafe fn UART5() {
        // SAFETY: UART5's vector is the middle executor's alone (the peripheral is not used).
        unsafe { MIDDLE.on_interrupt() }
    }

    /// The time base: embassy-time's instant in nanoseconds.
    #[derive(Clone, Copy)]
    struct EmbassyTime;

    impl TimeBase for EmbassyTime {
        fn now(&self) -> Nanos {
            Instant::now().as_micros() * 1000
        }

        async fn wait_until(&mut self, at: Nanos) {
            Timer::at(Instant::from_micros(at / 1000)).await;
        }
    }

    // `fn board_config()`: the built-in `tetra` board, or the parts and arrangement of the file
    // `BALLISTO_ARRANGEMENT` named at build time (build.rs).
    include!(concat!(env!("OUT_DIR"), "/board_config.rs"));

    static SAMPLES: Channel<Cs, SampleSet, { ballisto_fw::QUEUE }> = Channel::new();
    static HEALTH: HealthBoard<Cs> = HealthBoard::new();
    static SPI1: StaticCell<Mutex<Cs, SpiBus>> = StaticCell::new();
    static I2C1: StaticCell<Mutex<Cs, I2cBus>> = StaticCell::new();
    static SAMPLER: StaticCell<Board> = StaticCell::new();
    static APP: StaticCell<App> = StaticCell::new();
    static TELEMETRY: StaticCell<Telemetry<UartTx<'static, Async>>> = StaticCell::new();
    static SLOTS: StaticCell<[Incoming; COMMAND_QUEUE]> = StaticCell::new();
    static COMMANDS: StaticCell<ZeroCopyChannel<'static, Cs, Incoming>> = StaticCell::new();
    static RX_DMA: StaticCell<[u8; 256]> = StaticCell::new();
    static BUILDS: StaticCell<Builds> = StaticCell::new();
    // Initialised at run time: a const-initialised one is 9 KB of .data, in flash.
    static IDENTIFIER: StaticCell<Identifier> = StaticCell::new();
    static WINDOW: StaticCell<Identification> = StaticCell::new();
    static STORE: StaticCell<Store> = StaticCell::new();
    static COMMIT_REQUESTS: CommitRequests<Cs> = CommitRequests::new();
    static COMMIT_REPLIES: CommitReplies<Cs> = CommitReplies::new();
    /// The calibration store: bank 2's first two 128 KiB sectors (offsets from 0x0800_0000;
    /// `memory.x` keeps the image in bank 1).
    const CAL_RANGE: core::ops::Range<u32> = 0x10_0000..0x14_0000;

    /// The boot count's two words (`ballisto_fw::boot`): in `.uninit`, which the start-up code
    /// neither zeroes nor loads, so a reset leaves them as the last boot wrote them.
    #[link_section = ".uninit.BOOTS"]
    static mut BOOTS: core::mem::MaybeUninit<[u32; 2]> = core::mem::MaybeUninit::uninit();

    /// Why the unit started (RCC_RSR, then cleared so the next reset's flags stand alone) and
    /// which boot since power-on this is. After a power-on or brown-out the count's words are
    /// not read: their RAM came up with no valid ECC.
    #[inline(never)]
    fn boot_info() -> BootInfo {
        let rsr = pac::RCC.rsr().read();
        pac::RCC.rsr().write(|w| w.set_rmvf(true));
        // Every reset also drives NRST, so the pin flag comes last.
        let cause = if rsr.porrstf() || rsr.borrstf() {
            ResetCause::PowerOn
        } else if rsr.iwdg1rstf() || rsr.wwdg1rstf() {
            ResetCause::Watchdog
        } else if rsr.sftrstf() {
            ResetCause::Software
        } else if rsr.lpwrrstf() {
            ResetCause::Other
        } else if rsr.pinrstf() {
            ResetCause::Pin
        } else {
            ResetCause::Unknown
        };
        let words = core::ptr::addr_of_mut!(BOOTS).cast::<[u32; 2]>();
        let mut retained = [0u32; 2];
        if cause != ResetCause::PowerOn {
            // SAFETY: `BOOTS` is this function's alone (called once, before the tasks), and
            // aligned; after a reset other than power-on its RAM holds what the last boot wrote.
            retained = unsafe { words.read_volatile() };
        }
        let boot = count_boot(&mut retained, cause);
        // SAFETY: as above.
        unsafe { words.write_volatile(retained) };
        boot
    }

    /// The calibration to run: the store's newest whole record for the configured channels,
    /// else the built-in arrangement (logged either way), and the store for the storage task.
    /// Polled to completion here (the H7's flash operations block anyway).
    fn calibration_at_boot(
        flash: embassy_stm32::Peri<'static, embassy_stm32::peripherals::FLASH>,
        config: &mut AppConfig,
    ) -> (CalibrationId, Option<Store>) {
        // Read only: booting never writes (a damaged record is left for the next commit).
        let flash = ReadOnly(BlockingAsync::new(Flash::new_blocking(flash)));
        let Ok(mut store) = CalibrationStore::new(flash, CAL_RANGE) else {
            error!("calibration store range invalid: built-in arrangement");
            return (CalibrationId::default(), None);
        };
        let (arrangement, id, why) =
            embassy_futures::block_on(select_at_boot(&mut store, &config.arrangement));
        // One line (0 from flash, 1 nothing stored, 2 another channel count, 3 unreadable): the
        // image had 268 B too few for four.
        let reason = match why {
            None => 0u8,
            Some(NotUsed::Empty) => 1,
            Some(NotUsed::Channels { .. }) => 2,
            Some(NotUsed::Store(_)) => 3,
        };
        info!(
            "calibration: id {} CRC {:#010x} (0 from flash; 1 none stored, 2 other channels, 3 unreadable: built-in): {}",
            id.id, id.crc, reason
        );
        config.arrangement = arrangement;
        let store = CalibrationStore::new(store.into_flash().0, CAL_RANGE).ok();
        (id, store)
    }
    /// No observer on the flight board: nothing is queued there.
    static OBSERVATIONS: Observations<Cs> = Observations::new();
    static LIVENESS: Liveness = Liveness::new();

    /// IWDG1: 1 s without a feed resets the unit; the next boot reads the cause in RCC_RSR.
    struct Iwdg(IndependentWatchdog<'static, peripherals::IWDG1>);

    impl Watchdog for Iwdg {
        fn feed(&mut self) {
            self.0.pet()
        }
    }

    /// Feeds the watchdog while the sets come and are handled (the upper executor: nothing
    /// below can hold it up).
    #[embassy_executor::task]
    async fn supervisor(mut watchdog: Iwdg) {
        let mut time = EmbassyTime;
        supervisor_task(&HEALTH, &LIVENESS, &mut watchdog, &mut time, |stall| {
            error!("{:?} stalled: the watchdog is no longer fed", stall)
        })
        .await
    }

    #[embassy_executor::task]
    async fn sampling(sampler: &'static mut Board) {
        let mut time = EmbassyTime;
        sampler.start(&time, None).await;
        sampling_task(sampler, &mut time, SAMPLES.sender(), &HEALTH, None).await;
    }

    /// Builds the estimator's configurations (the middle executor: below the estimate, above
    /// the identification).
    #[embassy_executor::task]
    async fn builder(builds: &'static Builds) {
        builds.run().await
    }

    /// The identification's window: sums, solve and search (thread mode: below everything).
    #[embassy_executor::task]
    async fn identification(identifier: &'static Identifier, window: &'static mut Identification) {
        identifier.run(window).await
    }

    /// Commits calibrations (the middle executor: an erase must not hold up the estimate).
    #[embassy_executor::task]
    async fn storage(store: &'static mut Store) {
        storage_task(store, COMMIT_REQUESTS.receiver(), COMMIT_REPLIES.sender()).await
    }

    #[embassy_executor::task]
    async fn uplink(
        rx: RingBufferedUartRx<'static>,
        commands: zerocopy_channel::Sender<'static, Cs, Incoming>,
    ) {
        uplink_task(rx, commands).await;
        error!("uplink: the receiver stopped");
    }

    #[embassy_executor::task]
    async fn application(
        app: &'static mut App,
        tm: &'static mut Telemetry<UartTx<'static, Async>>,
        commands: zerocopy_channel::Receiver<'static, Cs, Incoming>,
        writable: bool,
    ) {
        let links = Links {
            samples: SAMPLES.receiver(),
            commands,
            health: &HEALTH,
            telemetry: tm,
            observations: &OBSERVATIONS,
            liveness: &LIVENESS,
            storage: writable.then(|| StorageLinks {
                requests: COMMIT_REQUESTS.sender(),
                replies: COMMIT_REPLIES.receiver(),
            }),
        };
        app_task(app, &EmbassyTime, links).await;
    }

    /// HSI 64 MHz → PLL1 400 MHz core (VOS1), 200 MHz AXI/AHB, 100 MHz APB.
    fn clocks() -> embassy_stm32::Config {
        let mut config = embassy_stm32::Config::default();
        let rcc = &mut config.rcc;
        rcc.hsi = Some(rcc::HSIPrescaler::DIV1);
        rcc.pll1 = Some(rcc::Pll {
            source: rcc::PllSource::HSI,
            prediv: rcc::PllPreDiv::DIV4,
            mul: rcc::PllMul::MUL50,
            fracn: None,
            divp: Some(rcc::PllDiv::DIV2),
            divq: Some(rcc::PllDiv::DIV8),
            divr: None,
        });
        rcc.sys = rcc::Sysclk::PLL1_P;
        rcc.ahb_pre = rcc::AHBPrescaler::DIV2;
        rcc.apb1_pre = rcc::APBPrescaler::DIV2;
        rcc.apb2_pre = rcc::APBPrescaler::DIV2;
        rcc.apb3_pre = rcc::APBPrescaler::DIV2;
        rcc.apb4_pre = rcc::APBPrescaler::DIV2;
        rcc.voltage_scale = rcc::VoltageScale::Scale1;
        config
    }

    #[embassy_executor::main]
    async fn main(spawner: Spawner) {
        let boot = boot_info();
        let p = embassy_stm32::init(clocks());
        info!("ballistometer {}", env!("CARGO_PKG_VERSION"));
        let Some(mut config) = board_config() else {
            error!("the board's configuration is refused");
            return;
        };
        let (calibration, store) = calibration_at_boot(p.FLASH, &mut config);

        let mut spi_config = spi::Config::default();
        spi_config.frequency = Hertz(10_000_000);
        spi_config.mode = spi::MODE_0;
        let spi = Spi::new(
            p.SPI1, p.PA5, p.PB5, p.PA6, p.DMA1_CH0, p.DMA1_CH1, Irqs, spi_config,
        );
        let spi = &*SPI1.init(Mutex::new(spi));
        let mut i2c_config = i2c::Config::default();
        i2c_config.frequency = Hertz(400_000);
        let i2c = I2c::new(
            p.I2C1, p.PB8, p.PB9, p.DMA1_CH2, p.DMA1_CH3, Irqs, i2c_config,
        );
        let i2c = &*I2C1.init(Mutex::new(i2c));

        let cs = [
            Output::new(p.PD14, Level::High, Speed::VeryHigh),
            Output::new(p.PD15, Level::High, Speed::VeryHigh),
            Output::new(p.PF12, Level::High, Speed::VeryHigh),
            Output::new(p.PF13, Level::High, Speed::VeryHigh),
        ];
        let mut buses: [Option<PartBus<Part, I2cPart>>; MAX_PARTS] = Default::default();
        for (slot, cs) in buses.iter_mut().zip(cs) {
            *slot = Some(PartBus::Spi(SpiDevice::new(spi, cs)));
        }
        // LIS3DH parts of other configurations sit on I2C1 at 0x18 / 0x19.
        for (i, part) in config.sampling.parts() {
            if matches!(part.kind, PartKind::Lis3dh { .. }) {
                let address = if i % 2 == 0 { 0x18 } else { 0x19 };
                buses[i] = Some(PartBus::I2c(I2cDevice::new(i2c), address));
            }
        }
        let sync = Output::new(p.PE9, Level::Low, Speed::VeryHigh);
        let sampler = SAMPLER.init(Sampler::new(&config.sampling, buses, sync));

        let mut uart_config = usart::Config::default();
        uart_config.baudrate = 921_600;
        let Ok(uart) = Uart::new(
            p.USART2,
            p.PD6,
            p.PD5,
            p.DMA1_CH4,
            p.DMA1_CH5,
            Irqs,
            uart_config,
        ) else {
            error!("USART2 configuration refused");
            return;
        };
        let (tx, rx) = uart.split();
        let rx = rx.into_ring_buffered(RX_DMA.init([0; 256]));

        let builds = BUILDS.init_with(Builds::background);
        let identifier: &'static Identifier = IDENTIFIER.init_with(Identifier::new);
        let app = match App::new(&config, Mode::Operate) {
            Ok(mut app) => {
                app.set_calibration(calibration);
                app.set_boot_info(boot);
                app.attach_builds(builds);
                app.attach_identifier(identifier);
                app
            }
            Err(e) => {
                error!("the built-in configuration is refused: {:?}", e);
                return;
            }
        };
        let app = APP.init(app);
        let tm = TELEMETRY.init(Telemetry::new(tx));
        let slots = SLOTS.init_with(|| core::array::from_fn(|_| Incoming::new()));
        let (command_tx, command_rx) = COMMANDS.init(ZeroCopyChannel::new(slots)).split();

        spawner.spawn(identification(identifier, WINDOW.init_with(Identification::new)).unwrap());
        interrupt::UART5.set_priority(Priority::P7);
        let middle = MIDDLE.start(interrupt::UART5);
        middle.spawn(builder(builds).unwrap());
        let writable = store.is_some();
        if let Some(store) = store {
            middle.spawn(storage(STORE.init(store)).unwrap());
        }
        interrupt::UART4.set_priority(Priority::P6);
        let upper = UPPER.start(interrupt::UART4);
        upper.spawn(sampling(sampler).unwrap());
        upper.spawn(uplink(rx, command_tx).unwrap());
        upper.spawn(application(app, tm, command_rx, writable).unwrap());
        // Armed last, once everything it watches is spawned; it cannot be stopped.
        let mut watchdog = IndependentWatchdog::new(p.IWDG1, 1_000_000);
        watchdog.unleash();
        upper.spawn(supervisor(Iwdg(watchdog)).unwrap());
    }
}

#[cfg(not(target_os = "none"))]
fn main() {
    eprintln!(
        "board-stm32h743 runs on the STM32H743: cd firmware/boards/stm32h743 && cargo run --profile flight"
    );
    std::process::exit(2);
}
