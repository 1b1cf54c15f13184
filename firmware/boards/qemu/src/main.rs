//! The ballistometer on QEMU mps2-an386 (Cortex-M4F): the application of the `firmware`
//! crate on the embassy executor, with
//! - a SysTick time base (1 ms periods of the 25 MHz core clock, counted in its exception,
//!   which also wakes the tasks waiting for a time),
//! - three priorities: sampling, the application and the observer on an interrupt executor
//!   (a software-pended interrupt); below them on a second the builder of the estimator's
//!   configurations (issue 17: a part's exclusion is precomputed there, in soft f64 on this
//!   Cortex-M4F, while the estimates go on) and the calibration storage task; in thread mode,
//!   below everything, the identification task (the window's sums, solve and search, soft f64
//!   too) and the scripted uplink,
//! - the built-in scenario in place of the parts (QEMU has no accelerometers) and its
//!   scripted uplink,
//! - the telemetry link (`link`) written through semihosting into QEMU's working directory:
//!   `telemetry-boot1.bin`, `telemetry.bin` (boot 2), `telemetry-boot3.bin`, and to UART0,
//!   QEMU's first serial port (`-serial pty`: followed live by `ballisto capture`),
//! - a RAM-backed flash for the calibration store in the SSRAM QEMU maps as flash, beyond the
//!   image. At power-on (the store erased) boot 1 runs the nominal arrangement while the
//!   scripted ground identifies the geometry and commits it (`demo::identification`), then
//!   resets the machine; boot 2 runs the calibration read back (`demo::boot`) through the
//!   built-in scenario's faults and commands, then its sets stop: the supervisor stops feeding
//!   the CMSDK watchdog (armed at boot, 1 s), which resets the machine; boot 3 says so (reset
//!   cause watchdog, from the mark its NMI leaves) and estimates on the stored calibration.
//!
//! With `tumble` on the semihosting command line the scenario is `board_qemu::tumble` instead
//! (identification without a reference: boot 1 searches a torque-free tumble for the geometry
//! and commits it, boot 2 runs on it), which `scripts/qemu-board-m7.sh` runs on mps2-an500, the
//! Cortex-M7 with the double-precision FPU the search needs.
//!
//! Boot 3 (the tumble's boot 2) runs its sets, prints a summary and exits with status 0, or 1
//! if telemetry was lost, a file could not be written, nothing was estimated or a reset came
//! that the scenario does not have.
//! `cargo run -p board-qemu --profile flight --target thumbv7em-none-eabihf` (the runner,
//! `.cargo/qemu-runner.sh`, writes into `out/qemu/`).
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(target_os = "none")]
mod link;

#[cfg(target_os = "none")]
mod board {
    use core::cell::RefCell;
    use core::sync::atomic::{AtomicU32, Ordering};
    use core::task::Poll;

    use ballisto_fw::app::{
        app_task, uplink_task, App, Incoming, Links, Mode, Observations, COMMAND_QUEUE,
    };
    use ballisto_fw::boot::{count_boot, ResetCause};
    use ballisto_fw::calstore::{CalibrationStore, Programming, RamFlash};
    use ballisto_fw::estimation::Builds;
    use ballisto_fw::identification::{Identification, Identifier};
    use ballisto_fw::sampler::{HealthBoard, SampleSet};
    use ballisto_fw::storage::{storage_task, CommitReplies, CommitRequests, StorageLinks};
    use ballisto_fw::supervisor::{supervisor_task, Liveness, Watchdog};
    use ballisto_fw::telemetry::Telemetry;
    use ballisto_fw::time::{Nanos, TimeBase};
    use board_qemu::demo::{self, Script, ScriptedUplink, BOOT1_SETS, BOOT3_SETS, SETS};
    use board_qemu::synthetic::{synthetic_task, Synthetic};
    use board_qemu::tumble;

    use crate::link::{BoardLink, HostFile, Uart};
    use cortex_m::interrupt::InterruptNumber;
    use cortex_m::peripheral::scb::SystemHandler;
    use cortex_m::peripheral::syst::SystClkSource;
    use cortex_m::peripheral::SYST;
    use cortex_m_rt::exception;
    use cortex_m_semihosting::{debug, hprintln};
    use embassy_executor::{InterruptExecutor, Spawner};
    use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex as Cs;
    use embassy_sync::blocking_mutex::Mutex as BlockingMutex;
    use embassy_sync::channel::Channel;
    use embassy_sync::waitqueue::MultiWakerRegistration;
    use embassy_sync::zerocopy_channel::{self, Channel as ZeroCopyChannel};
    use embedded_io_async::Write;
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

    /// An interrupt line an executor runs in: one of the NVIC's lines that no device of
    /// mps2-an386 drives, pended only by the executor itself.
    #[derive(Clone, Copy)]
    struct SoftwareLine(u16);

    // SAFETY: both lines used (`UPPER_LINE`, `MIDDLE_LINE`) are valid interrupt numbers of the
    // machine's NVIC (32 lines).
    unsafe impl InterruptNumber for SoftwareLine {
        fn number(self) -> u16 {
            self.0
        }
    }

    /// Sampling, the application and the observer: above everything else.
    static UPPER: InterruptExecutor = InterruptExecutor::new();
    const UPPER_LINE: SoftwareLine = SoftwareLine(31);

    /// The builder of configurations and the storage task: below the upper executor, above
    /// thread mode, where the identification task and the scripted uplink run.
    static MIDDLE: InterruptExecutor = InterruptExecutor::new();
    const MIDDLE_LINE: SoftwareLine = SoftwareLine(30);

    /// Without a device crate every external interrupt comes here (cortex-m-rt's default
    /// vector table): each executor's line polls it; any other is not expected.
    #[exception]
    unsafe fn DefaultHandler(irqn: i16) {
        if irqn == UPPER_LINE.0 as i16 {
            // SAFETY: called from the executor's interrupt only.
            unsafe { UPPER.on_interrupt() }
        } else if irqn == MIDDLE_LINE.0 as i16 {
            // SAFETY: called from the middle executor's interrupt only.
            unsafe { MIDDLE.on_interrupt() }
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

    static SAMPLES: Channel<Cs, SampleSet, { ballisto_fw::QUEUE }> = Channel::new();
    static SLOTS: StaticCell<[Incoming; COMMAND_QUEUE]> = StaticCell::new();
    static COMMANDS: StaticCell<ZeroCopyChannel<'static, Cs, Incoming>> = StaticCell::new();
    static HEALTH: HealthBoard<Cs> = HealthBoard::new();
    static APP: StaticCell<App> = StaticCell::new();
    static BUILDS: StaticCell<Builds> = StaticCell::new();
    // Initialised at run time: a const-initialised one is 9 KB of .data, in flash.
    static IDENTIFIER: StaticCell<Identifier> = StaticCell::new();
    static WINDOW: StaticCell<Identification> = StaticCell::new();
    static SOURCE: StaticCell<Synthetic> = StaticCell::new();
    static TELEMETRY: StaticCell<Telemetry<BoardLink<SysTickTime>>> = StaticCell::new();
    /// Sector of the RAM-backed calibration flash.
    const CAL_SECTOR: usize = 4096;
    /// The calibration flash: two sectors of the SSRAM QEMU maps at 0 as flash, at 3 MiB.
    const CAL_ADDR: usize = 0x0030_0000;
    /// The stage marker, just below it: which boot of the scenario is done (survives the
    /// reset).
    const STAGE_ADDR: usize = CAL_ADDR - 16;
    const FIRST_BOOT_DONE: u32 = 0x5EED_CA11;
    const SECOND_BOOT_DONE: u32 = 0x5EED_CA12;
    /// The boot count's two words (`ballisto_fw::boot`), after the stage marker.
    const BOOTS_ADDR: usize = STAGE_ADDR + 4;
    /// The watchdog's mark, after the boot count: its interrupt fired (the reset follows).
    const WATCHDOG_ADDR: usize = STAGE_ADDR + 12;
    const WATCHDOG_FIRED: u32 = 0xD06_F1ED;

    /// Which boot of the built-in scenario this is.
    #[derive(Clone, Copy, Debug, PartialEq)]
    enum Stage {
        /// Power-on: the identification, then the board's own reset.
        One,
        /// On the record: the scenario's faults and commands; then the sets stop (the demo).
        Two,
        /// After the watchdog's reset: the estimate on the record again (the demo).
        Three,
    }

    /// mps2-an386's CMSDK APB watchdog at 0x4000_8000, counting the 25 MHz system clock. QEMU
    /// wires its interrupt to the NMI and resets the machine when it expires again with the
    /// interrupt not cleared.
    struct CmsdkWatchdog;

    const WDOG: usize = 0x4000_8000;
    const WDOG_LOAD: usize = WDOG;
    const WDOG_CONTROL: usize = WDOG + 0x08;
    const WDOG_INTCLR: usize = WDOG + 0x0C;
    const WDOG_LOCK: usize = WDOG + 0xC00;
    const WDOG_UNLOCK: u32 = 0x1ACC_E551;

    impl CmsdkWatchdog {
        /// Arms it: the interrupt after 0.5 s without a feed, the reset 0.5 s later.
        fn arm() -> Self {
            // SAFETY: the watchdog's registers, used by nothing else; unlocked, written, locked.
            unsafe {
                (WDOG_LOCK as *mut u32).write_volatile(WDOG_UNLOCK);
                (WDOG_LOAD as *mut u32).write_volatile(12_500_000);
                // INTEN | RESEN.
                (WDOG_CONTROL as *mut u32).write_volatile(0b11);
                (WDOG_LOCK as *mut u32).write_volatile(0);
            }
            CmsdkWatchdog
        }
    }

    impl Watchdog for CmsdkWatchdog {
        fn feed(&mut self) {
            // SAFETY: as in `arm`; a write to INTCLR reloads the count.
            unsafe {
                (WDOG_LOCK as *mut u32).write_volatile(WDOG_UNLOCK);
                (WDOG_INTCLR as *mut u32).write_volatile(1);
                (WDOG_LOCK as *mut u32).write_volatile(0);
            }
        }
    }

    /// The watchdog's first expiry: marked for the next boot's reset cause (QEMU has no
    /// reset-cause register); the reset follows at the second.
    #[exception]
    unsafe fn NonMaskableInt() {
        // SAFETY: the mark's word lies with the stage marker, used by nothing else.
        unsafe { (WATCHDOG_ADDR as *mut u32).write_volatile(WATCHDOG_FIRED) };
    }
    static CAL_ERASES: StaticCell<[u32; 2]> = StaticCell::new();
    type Store = CalibrationStore<RamFlash<'static, CAL_SECTOR, 32>>;
    static STORE: StaticCell<Store> = StaticCell::new();
    static COMMIT_REQUESTS: CommitRequests<Cs> = CommitRequests::new();
    static COMMIT_REPLIES: CommitReplies<Cs> = CommitReplies::new();
    static OBSERVATIONS: Observations<Cs> = Observations::new();
    static LIVENESS: Liveness = Liveness::new();

    #[embassy_executor::task]
    async fn sampling(source: &'static mut Synthetic, t0: Nanos, sets: u32) {
        let queue = SAMPLES.sender();
        synthetic_task(source, &mut SysTickTime, queue, &HEALTH, t0, Some(sets)).await;
    }

    #[embassy_executor::task]
    async fn uplink(
        t0: Nanos,
        period: Nanos,
        script: Script,
        commands: zerocopy_channel::Sender<'static, Cs, Incoming>,
    ) {
        uplink_task(
            ScriptedUplink::new(&SysTickTime, t0, period, script),
            commands,
        )
        .await;
    }

    /// Commits calibrations (the middle executor: a flash erase must not hold up the estimate).
    #[embassy_executor::task]
    async fn storage(store: &'static mut Store) {
        storage_task(store, COMMIT_REQUESTS.receiver(), COMMIT_REPLIES.sender()).await
    }

    #[embassy_executor::task]
    async fn application(
        app: &'static mut App,
        tm: &'static mut Telemetry<BoardLink<SysTickTime>>,
        commands: zerocopy_channel::Receiver<'static, Cs, Incoming>,
    ) {
        let links = Links {
            samples: SAMPLES.receiver(),
            commands,
            health: &HEALTH,
            telemetry: tm,
            observations: &OBSERVATIONS,
            liveness: &LIVENESS,
            storage: Some(StorageLinks {
                requests: COMMIT_REQUESTS.sender(),
                replies: COMMIT_REPLIES.receiver(),
            }),
        };
        app_task(app, &SysTickTime, links).await;
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

    /// Feeds the watchdog while the sets come and are handled.
    #[embassy_executor::task]
    async fn supervisor(mut watchdog: CmsdkWatchdog) {
        supervisor_task(
            &HEALTH,
            &LIVENESS,
            &mut watchdog,
            &mut SysTickTime,
            |stall| {
                hprintln!(
                    "board-qemu: {:?} stalled: the watchdog is no longer fed",
                    stall
                )
            },
        )
        .await
    }

    /// Ends the boot once the application has handled its last set: boot 1 resets the
    /// machine; the demo's boot 2 lets its sets stop (the supervisor stops feeding the
    /// watchdog, which resets the machine), the tumble's ends the run; boot 3 ends the run.
    #[embassy_executor::task]
    async fn observer(sets: u32, stage: Stage, tumbling: bool) {
        let Ok(mut seen) = OBSERVATIONS.subscriber() else {
            finish(false)
        };
        loop {
            let o = seen.next_message_pure().await;
            // The last set, or the first after the source's last (the last may have been
            // dropped while the application was busy).
            if o.set.k + 1 >= sets || o.status.sampling.sets >= sets {
                let s = o.status;
                hprintln!(
                    "board-qemu: boot {}: {} sets, {} estimates, {} packets sent ({} lost), {} telecommands accepted, {} refused, {} garbage frames; {} s on board",
                    stage as u8 + 1,
                    s.sampling.sets,
                    s.estimates,
                    s.tm_sent,
                    s.tm_lost,
                    s.tc_accepted,
                    s.tc_rejected,
                    s.frames_garbage,
                    SysTickTime.now() / 1_000_000_000
                );
                let ok = s.tm_lost == 0 && s.estimates > 0;
                match stage {
                    Stage::One if ok => {
                        // SAFETY: as in `main` (the stage marker's word, used by nothing else).
                        unsafe { (STAGE_ADDR as *mut u32).write_volatile(FIRST_BOOT_DONE) };
                        cortex_m::peripheral::SCB::sys_reset();
                    }
                    Stage::Two if ok && !tumbling => {
                        // SAFETY: as above.
                        unsafe { (STAGE_ADDR as *mut u32).write_volatile(SECOND_BOOT_DONE) };
                        hprintln!("board-qemu: boot 2: the sets stop");
                        return;
                    }
                    _ => finish(ok),
                }
            }
        }
    }

    /// Whether the semihosting command line names the tumble (`board_qemu::tumble`) as the
    /// built-in scenario to run; anything else, or no command line, runs `board_qemu::demo`.
    /// The machine's own configuration, as a board file's: the image is the same.
    fn runs_the_tumble() -> bool {
        let mut line = [0u8; 128];
        let mut block = [line.as_mut_ptr() as usize, line.len()];
        // SAFETY: SYS_GET_CMDLINE writes at most `block[1]` octets at `block[0]` (`line`) and
        // the length it wrote into `block[1]`; both outlive the call.
        let status = unsafe {
            cortex_m_semihosting::syscall1(
                cortex_m_semihosting::nr::GET_CMDLINE,
                block.as_mut_ptr() as usize,
            )
        };
        // SAFETY: the host wrote `block` behind the compiler's back.
        let len = unsafe { core::ptr::read_volatile(&block[1]) }.min(line.len());
        status == 0
            && line[..len]
                .split(|b| *b == b' ')
                .any(|word| word == b"tumble")
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

    /// The boot's parts, sets and uplink script: the built-in demo, or the tumble (chosen on
    /// the semihosting command line); boot 1 in free flight for the identification, boot 2
    /// with the scenario's faults, boot 3 without.
    fn scenario(tumbling: bool, stage: Stage) -> (Synthetic, u32, Script) {
        match (tumbling, stage) {
            (false, Stage::One) => {
                let source = Synthetic::new(&demo::truth(), None, None).in_free_flight();
                (source, BOOT1_SETS, demo::identification)
            }
            (false, Stage::Two) => {
                let source = Synthetic::new(&demo::truth(), Some(demo::OUTAGE), Some(demo::STUCK));
                (source, SETS, demo::script)
            }
            (_, Stage::Three) => {
                let source = Synthetic::new(&demo::truth(), None, None);
                (source, BOOT3_SETS, demo::quiet)
            }
            (true, Stage::One) => (
                tumble::source(Some(tumble::OUTAGE)),
                tumble::BOOT1_SETS,
                tumble::identification,
            ),
            (true, Stage::Two) => (tumble::source(None), tumble::SETS, demo::quiet),
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
            p.NVIC.set_priority(UPPER_LINE, 0x80);
            p.NVIC.set_priority(MIDDLE_LINE, 0xC0);
        }
        p.SYST.set_clock_source(SystClkSource::Core);
        p.SYST.set_reload(RELOAD);
        p.SYST.clear_current();
        p.SYST.enable_interrupt();
        p.SYST.enable_counter();

        // Calibration: identification → commit → reset → boot, with a reset of the machine.
        // The store is a RAM-backed flash of the STM32H743's word size in the part of the
        // SSRAM QEMU maps as flash beyond the image (`CAL_ADDR`): QEMU reloads only the image's
        // segments on a reset, so it keeps its contents as a flash would.
        // QEMU has no reset-cause register: the stage marker and the watchdog's mark are zero
        // after power-on (QEMU starts with that memory zeroed); the marker is set before the
        // board's own SYSRESETREQ and before the sets stop, the mark by the watchdog's NMI.
        let marker = STAGE_ADDR as *mut u32;
        let mark = WATCHDOG_ADDR as *mut u32;
        // SAFETY: `STAGE_ADDR .. + 16` lies in the 4 MiB flash region (memory.x) far beyond
        // the image (≈ 320 KiB), below `CAL_ADDR`; nothing else refers to it.
        let (stage, fired) = unsafe { (marker.read_volatile(), mark.read_volatile()) };
        let stage = match stage {
            FIRST_BOOT_DONE => Stage::Two,
            SECOND_BOOT_DONE => Stage::Three,
            _ => Stage::One,
        };
        let cause = match (stage, fired == WATCHDOG_FIRED) {
            (Stage::One, false) => ResetCause::PowerOn,
            (Stage::Two, false) => ResetCause::Software,
            (Stage::Three, true) => ResetCause::Watchdog,
            (stage, fired) => {
                hprintln!(
                    "board-qemu: boot {:?} after a reset not in the scenario (watchdog: {})",
                    stage,
                    fired
                );
                finish(false)
            }
        };
        // SAFETY: as above (a later power-on starts from an erased part again).
        unsafe { (marker.write_volatile(0), mark.write_volatile(0)) };
        // SAFETY: `BOOTS_ADDR .. + 8` lies between the stage marker and `CAL_ADDR`, used by
        // nothing else; aligned.
        let boot_info = count_boot(unsafe { &mut *(BOOTS_ADDR as *mut [u32; 2]) }, cause);
        let first = stage == Stage::One;
        if stage == Stage::Two {
            // The store as boot 1 left it, read out for the host's check (as a ground test
            // reads a flash through the debug port).
            // SAFETY: `CAL_ADDR .. + 2 sectors` lies in the flash region beyond the image;
            // read here before the store below takes it.
            let bytes =
                unsafe { core::slice::from_raw_parts(CAL_ADDR as *const u8, 2 * CAL_SECTOR) };
            let written = match HostFile::create("calibration-store.bin\0") {
                Some(mut f) => f.write_all(bytes).await.is_ok(),
                None => false,
            };
            if !written {
                hprintln!("board-qemu: cannot write calibration-store.bin");
                finish(false)
            }
        }
        // SAFETY: as above; the store is the only user of this memory from here on.
        let mem = unsafe { core::slice::from_raw_parts_mut(CAL_ADDR as *mut u8, 2 * CAL_SECTOR) };
        let erases = CAL_ERASES.init([0u32; 2]);
        let mut flash = RamFlash::<CAL_SECTOR, 32>::new(mem, erases, Programming::WordOnce);
        let range = 0..(2 * CAL_SECTOR) as u32;
        if first {
            // Power-on: an erased part.
            flash.erase_all();
        }
        let Ok((config, calibration, store)) = demo::boot(flash, range).await else {
            hprintln!("board-qemu: the calibration store failed at boot");
            finish(false)
        };
        let tumbling = runs_the_tumble();
        hprintln!(
            "board-qemu: boot {} of the {} runs {:?}",
            stage as u8 + 1,
            if tumbling { "tumble" } else { "demo" },
            calibration
        );
        let name = match stage {
            Stage::One => "telemetry-boot1.bin\0",
            Stage::Two => "telemetry.bin\0",
            Stage::Three => "telemetry-boot3.bin\0",
        };
        let Some(file) = HostFile::create(name) else {
            hprintln!("board-qemu: cannot create {}", name);
            finish(false)
        };
        let Ok(mut app) = App::new(&config, Mode::Operate) else {
            hprintln!("board-qemu: the built-in configuration is invalid");
            finish(false)
        };
        app.set_calibration(calibration);
        app.set_boot_info(boot_info);
        let builds = BUILDS.init_with(Builds::background);
        let identifier: &'static Identifier = IDENTIFIER.init_with(Identifier::new);
        app.attach_builds(builds);
        app.attach_identifier(identifier);
        let app = APP.init(app);
        // The parts as mounted (`demo::truth`).
        let (source, sets, script) = scenario(tumbling, stage);
        let source = SOURCE.init(source);
        let link = BoardLink {
            file,
            uart: Uart::enable(SysTickTime),
        };
        let tm = TELEMETRY.init(Telemetry::new(link));
        spawner.spawn(identification(identifier, WINDOW.init_with(Identification::new)).unwrap());
        let middle = MIDDLE.start(MIDDLE_LINE);
        middle.spawn(builder(builds).unwrap());
        middle.spawn(storage(STORE.init(store)).unwrap());
        let upper = UPPER.start(UPPER_LINE);
        let period = source.period();
        let t0 = SysTickTime.now() + period;
        upper.spawn(sampling(source, t0, sets).unwrap());
        let slots = SLOTS.init_with(|| core::array::from_fn(|_| Incoming::new()));
        let (command_tx, command_rx) = COMMANDS.init(ZeroCopyChannel::new(slots)).split();
        // The scripted uplink looks at the time by yielding (on the host it must not drive the
        // simulated clock): in thread mode, beside the builder, it cannot starve it.
        spawner.spawn(uplink(t0, period, script, command_tx).unwrap());
        upper.spawn(observer(sets, stage, tumbling).unwrap());
        // Armed last, once everything it watches is spawned.
        upper.spawn(supervisor(CmsdkWatchdog::arm()).unwrap());
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
