//! The ballistometer on QEMU mps2-an386 (Cortex-M4F): the application of the `firmware`
//! crate on the embassy executor, with
//! - a SysTick time base (1 ms periods of the 25 MHz core clock, counted in its exception,
//!   which also wakes the tasks waiting for a time),
//! - two priorities: sampling, the application and the observer on an interrupt executor (a
//!   software-pended interrupt), and below them, in thread mode, the builder of the
//!   estimator's configurations (issue 17: a part's exclusion is precomputed there, in soft
//!   f64 on this Cortex-M4F, while the estimates go on) and the scripted uplink,
//! - the built-in scenario in place of the parts (QEMU has no accelerometers) and its
//!   scripted uplink,
//! - the telemetry link written to `telemetry.bin` in QEMU's working directory through
//!   semihosting,
//! - a RAM-backed flash for the calibration store in the SSRAM QEMU maps as flash, beyond the
//!   image: at power-on the first boot commits calibration 1 and resets the machine
//!   (`demo::first_boot`); the second boot runs the arrangement read back (`demo::boot`).
//!
//! It runs [`ballisto_fw::demo::SETS`] sets, prints a summary and exits with status 0, or 1
//! if telemetry was lost, the file could not be written or nothing was estimated.
//! `cargo run -p board-qemu --profile flight --target thumbv7em-none-eabihf` (the runner,
//! `.cargo/qemu-runner.sh`, writes into `out/qemu/`).
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(target_os = "none")]
mod board {
    use core::cell::RefCell;
    use core::sync::atomic::{AtomicU32, Ordering};
    use core::task::Poll;

    use ballisto_fw::app::{
        app_task, uplink_task, App, Incoming, Links, Mode, Observations, COMMAND_QUEUE,
    };
    use ballisto_fw::boot::{count_boot, ResetCause};
    use ballisto_fw::calstore::{Programming, RamFlash};
    use ballisto_fw::demo::{self, ScriptedUplink, SETS};
    use ballisto_fw::estimation::Builds;
    use ballisto_fw::sampler::synthetic::{synthetic_task, Synthetic};
    use ballisto_fw::sampler::{HealthBoard, SampleSet};
    use ballisto_fw::telemetry::Telemetry;
    use ballisto_fw::time::{Nanos, TimeBase};
    use cortex_m::interrupt::InterruptNumber;
    use cortex_m::peripheral::scb::SystemHandler;
    use cortex_m::peripheral::syst::SystClkSource;
    use cortex_m::peripheral::SYST;
    use cortex_m_rt::exception;
    use cortex_m_semihosting::{debug, hprintln, syscall};
    use embassy_executor::{InterruptExecutor, Spawner};
    use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex as Cs;
    use embassy_sync::blocking_mutex::Mutex as BlockingMutex;
    use embassy_sync::channel::Channel;
    use embassy_sync::waitqueue::MultiWakerRegistration;
    use embassy_sync::zerocopy_channel::{self, Channel as ZeroCopyChannel};
    use embedded_io_async::{ErrorKind, ErrorType, Write};
    use static_cell::StaticCell;

    /// SysTick counts the 25 MHz core clock: 40 ns per count.
    const NS_PER_COUNT: u64 = 40;
    /// One SysTick period: 1 ms (the resolution of a wait).
    const COUNTS_PER_WRAP: u32 = 25_000;
    const RELOAD: u32 = COUNTS_PER_WRAP - 1;
    static WRAPS: AtomicU32 = AtomicU32::new(0);
    /// The tasks waiting for a time: woken at every SysTick, they look at the time again.
    static WAITING: BlockingMutex<Cs, RefCell<MultiWakerRegistration<4>>> =
        BlockingMutex::new(RefCell::new(MultiWakerRegistration::new()));

    #[exception]
    fn SysTick() {
        WRAPS.fetch_add(1, Ordering::Relaxed);
        WAITING.lock(|w| w.borrow_mut().wake());
    }

    /// The interrupt the upper executor runs in: one of the NVIC's lines that no device of
    /// mps2-an386 drives, pended only by the executor itself.
    #[derive(Clone, Copy)]
    struct SoftwareInterrupt;

    const EXECUTOR_IRQ: u16 = 31;

    // SAFETY: 31 is a valid interrupt number of the machine's NVIC (32 lines).
    unsafe impl InterruptNumber for SoftwareInterrupt {
        fn number(self) -> u16 {
            EXECUTOR_IRQ
        }
    }

    /// Sampling, the application and the observer: above thread mode, where the builder of
    /// configurations and the scripted uplink run.
    static UPPER: InterruptExecutor = InterruptExecutor::new();

    /// Without a device crate every external interrupt comes here (cortex-m-rt's default
    /// vector table): the executor's line polls it; any other is not expected.
    #[exception]
    unsafe fn DefaultHandler(irqn: i16) {
        if irqn == EXECUTOR_IRQ as i16 {
            // SAFETY: called from the executor's interrupt only.
            unsafe { UPPER.on_interrupt() }
        } else {
            hprintln!("board-qemu: unexpected interrupt {}", irqn);
            finish(false)
        }
    }

    /// The time base: SysTick counts extended by the wrap count.
    #[derive(Clone, Copy)]
    struct SysTickTime;

    impl TimeBase for SysTickTime {
        fn now(&self) -> Nanos {
            loop {
                let before = WRAPS.load(Ordering::Acquire);
                let count = SYST::get_current();
                if WRAPS.load(Ordering::Acquire) == before {
                    let ticks =
                        u64::from(before) * u64::from(COUNTS_PER_WRAP) + u64::from(RELOAD - count);
                    return ticks * NS_PER_COUNT;
                }
            }
        }

        async fn wait_until(&mut self, at: Nanos) {
            // Woken by the next SysTick (1 ms) to look again: the processor is free meanwhile
            // for the lower priority (busy-yielding here would keep the upper executor pended
            // and starve thread mode).
            core::future::poll_fn(|cx| {
                if self.now() >= at {
                    return Poll::Ready(());
                }
                WAITING.lock(|w| w.borrow_mut().register(cx.waker()));
                Poll::Pending
            })
            .await
        }
    }

    /// A host file opened through semihosting.
    struct HostFile(usize);

    impl HostFile {
        /// `name` must end with a NUL.
        fn create(name: &str) -> Option<Self> {
            let mode = cortex_m_semihosting::nr::open::W_TRUNC_BINARY;
            // SAFETY: SYS_OPEN reads `len` bytes at `ptr` (a NUL-terminated name).
            let fd = unsafe { syscall!(OPEN, name.as_ptr(), mode, name.len() - 1) } as isize;
            (fd >= 0).then_some(HostFile(fd as usize))
        }
    }

    impl ErrorType for HostFile {
        type Error = ErrorKind;
    }

    impl Write for HostFile {
        async fn write(&mut self, buf: &[u8]) -> Result<usize, ErrorKind> {
            // SAFETY: SYS_WRITE reads `len` bytes at `ptr`; returns the count NOT written.
            let left = unsafe { syscall!(WRITE, self.0, buf.as_ptr(), buf.len()) };
            match left {
                0 => Ok(buf.len()),
                n if n < buf.len() => Ok(buf.len() - n),
                _ => Err(ErrorKind::Other),
            }
        }

        async fn flush(&mut self) -> Result<(), ErrorKind> {
            Ok(())
        }
    }

    static SAMPLES: Channel<Cs, SampleSet, { ballisto_fw::QUEUE }> = Channel::new();
    static SLOTS: StaticCell<[Incoming; COMMAND_QUEUE]> = StaticCell::new();
    static COMMANDS: StaticCell<ZeroCopyChannel<'static, Cs, Incoming>> = StaticCell::new();
    static HEALTH: HealthBoard<Cs> = HealthBoard::new();
    static APP: StaticCell<App> = StaticCell::new();
    static BUILDS: StaticCell<Builds> = StaticCell::new();
    static SOURCE: StaticCell<Synthetic> = StaticCell::new();
    static TELEMETRY: StaticCell<Telemetry<HostFile>> = StaticCell::new();
    /// Sector of the RAM-backed calibration flash.
    const CAL_SECTOR: usize = 4096;
    /// The calibration flash: two sectors of the SSRAM QEMU maps at 0 as flash, at 3 MiB.
    const CAL_ADDR: usize = 0x0030_0000;
    /// The stage marker, just below it: the first boot is done (survives the reset).
    const STAGE_ADDR: usize = CAL_ADDR - 16;
    const FIRST_BOOT_DONE: u32 = 0x5EED_CA11;
    /// The boot count's two words (`ballisto_fw::boot`), after the stage marker.
    const BOOTS_ADDR: usize = STAGE_ADDR + 4;
    static CAL_ERASES: StaticCell<[u32; 2]> = StaticCell::new();
    static OBSERVATIONS: Observations<Cs> = Observations::new();

    #[embassy_executor::task]
    async fn sampling(source: &'static mut Synthetic, t0: Nanos) {
        let queue = SAMPLES.sender();
        synthetic_task(source, &mut SysTickTime, queue, &HEALTH, t0, Some(SETS)).await;
    }

    #[embassy_executor::task]
    async fn uplink(t0: Nanos, commands: zerocopy_channel::Sender<'static, Cs, Incoming>) {
        uplink_task(ScriptedUplink::new(&SysTickTime, t0), commands).await;
    }

    #[embassy_executor::task]
    async fn application(
        app: &'static mut App,
        tm: &'static mut Telemetry<HostFile>,
        commands: zerocopy_channel::Receiver<'static, Cs, Incoming>,
    ) {
        let links = Links {
            samples: SAMPLES.receiver(),
            commands,
            health: &HEALTH,
            telemetry: tm,
            observations: &OBSERVATIONS,
            storage: None,
        };
        app_task(app, &SysTickTime, links).await;
    }

    /// Builds the estimator's configurations (thread mode: below everything else).
    #[embassy_executor::task]
    async fn builder(builds: &'static Builds) {
        builds.run().await
    }

    /// Ends the run once the application has handled the last set of the scenario.
    #[embassy_executor::task]
    async fn observer() {
        let Ok(mut seen) = OBSERVATIONS.subscriber() else {
            finish(false)
        };
        loop {
            let o = seen.next_message_pure().await;
            if o.set.k + 1 >= SETS {
                let s = o.status;
                hprintln!(
                    "board-qemu: {} sets, {} estimates, {} packets sent ({} lost), {} telecommands accepted, {} refused, {} garbage frames; {} s on board",
                    s.sampling.sets,
                    s.estimates,
                    s.tm_sent,
                    s.tm_lost,
                    s.tc_accepted,
                    s.tc_rejected,
                    s.frames_garbage,
                    SysTickTime.now() / 1_000_000_000
                );
                finish(s.tm_lost == 0 && s.estimates > 0);
            }
        }
    }

    fn finish(ok: bool) -> ! {
        debug::exit(if ok {
            debug::EXIT_SUCCESS
        } else {
            debug::EXIT_FAILURE
        });
        loop {
            cortex_m::asm::wfi();
        }
    }

    #[embassy_executor::main]
    async fn main(spawner: Spawner) {
        let Some(mut p) = cortex_m::Peripherals::take() else {
            finish(false)
        };
        // SysTick above the upper executor, so that no period is missed while it runs.
        // SAFETY: priorities are set before the executor starts; no priority-based critical
        // section is in use.
        unsafe {
            p.SCB.set_priority(SystemHandler::SysTick, 0);
            p.NVIC.set_priority(SoftwareInterrupt, 0x80);
        }
        p.SYST.set_clock_source(SystClkSource::Core);
        p.SYST.set_reload(RELOAD);
        p.SYST.clear_current();
        p.SYST.enable_interrupt();
        p.SYST.enable_counter();

        // Calibration: the scenario's store → reset → boot, with a reset of the machine. The
        // store is a RAM-backed flash of the STM32H743's word size in the part of the SSRAM
        // QEMU maps as flash beyond the image (`CAL_ADDR`): QEMU reloads only the image's
        // segments on a reset, so it keeps its contents as a flash would.
        // SAFETY: `CAL_ADDR .. + 2 sectors` and `STAGE_ADDR` lie in the 4 MiB flash region
        // (memory.x) far beyond the image (≈ 120 KiB); nothing else refers to them.
        let mem = unsafe { core::slice::from_raw_parts_mut(CAL_ADDR as *mut u8, 2 * CAL_SECTOR) };
        let stage = STAGE_ADDR as *mut u32;
        let erases = CAL_ERASES.init([0u32; 2]);
        let mut flash = RamFlash::<CAL_SECTOR, 32>::new(mem, erases, Programming::WordOnce);
        let range = 0..(2 * CAL_SECTOR) as u32;
        // QEMU has no reset-cause register: the stage marker is zero after power-on (QEMU
        // starts with that memory zeroed), set after the board's own SYSRESETREQ.
        // SAFETY: as above.
        let cause = if unsafe { stage.read_volatile() } == FIRST_BOOT_DONE {
            ResetCause::Software
        } else {
            ResetCause::PowerOn
        };
        // SAFETY: `BOOTS_ADDR .. + 8` lies between the stage marker and `CAL_ADDR`, used by
        // nothing else; aligned.
        let boot_info = count_boot(unsafe { &mut *(BOOTS_ADDR as *mut [u32; 2]) }, cause);
        if cause == ResetCause::PowerOn {
            // Power-on: an erased part; the first boot (built-in), the commit, a reset.
            flash.erase_all();
            let Ok((first, _)) = demo::first_boot(flash, range).await else {
                hprintln!("board-qemu: the calibration store failed at boot 1");
                finish(false)
            };
            hprintln!(
                "board-qemu: boot 1 runs {:?}; calibration 1 committed; reset",
                first
            );
            // SAFETY: as above.
            unsafe { stage.write_volatile(FIRST_BOOT_DONE) };
            cortex_m::peripheral::SCB::sys_reset();
        }
        // SAFETY: as above (a later power-on starts from an erased part again).
        unsafe { stage.write_volatile(0) };
        let Ok((config, calibration, _)) = demo::boot(flash, range).await else {
            hprintln!("board-qemu: the calibration store failed at boot 2");
            finish(false)
        };
        hprintln!(
            "board-qemu: boot 2, after the reset, runs {:?}",
            calibration
        );
        let Some(file) = HostFile::create("telemetry.bin\0") else {
            hprintln!("board-qemu: cannot create telemetry.bin");
            finish(false)
        };
        let Ok(mut app) = App::new(&config, Mode::Operate) else {
            hprintln!("board-qemu: the built-in configuration is invalid");
            finish(false)
        };
        app.set_calibration(calibration);
        app.set_boot_info(boot_info);
        let builds = BUILDS.init_with(Builds::background);
        app.attach_builds(builds);
        let app = APP.init(app);
        let source = SOURCE.init(Synthetic::new(
            &config,
            Some(demo::OUTAGE),
            Some(demo::STUCK),
        ));
        let tm = TELEMETRY.init(Telemetry::new(file));
        spawner.spawn(builder(builds).unwrap());
        let upper = UPPER.start(SoftwareInterrupt);
        let t0 = SysTickTime.now() + source.period();
        upper.spawn(sampling(source, t0).unwrap());
        let slots = SLOTS.init_with(|| core::array::from_fn(|_| Incoming::new()));
        let (command_tx, command_rx) = COMMANDS.init(ZeroCopyChannel::new(slots)).split();
        // The scripted uplink looks at the time by yielding (on the host it must not drive the
        // simulated clock): in thread mode, beside the builder, it cannot starve it.
        spawner.spawn(uplink(t0, command_tx).unwrap());
        upper.spawn(observer().unwrap());
        upper.spawn(application(app, tm, command_rx).unwrap());
    }

    #[panic_handler]
    fn panic(info: &core::panic::PanicInfo) -> ! {
        hprintln!("board-qemu panicked: {}", info);
        finish(false)
    }
}

#[cfg(not(target_os = "none"))]
fn main() {
    eprintln!(
        "board-qemu runs under QEMU: cargo run -p board-qemu --profile flight --target thumbv7em-none-eabihf"
    );
    std::process::exit(2);
}
