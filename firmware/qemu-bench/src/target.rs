//! The Cortex-M platform of the bench: SysTick as the clock, semihosting for output.

use core::sync::atomic::{AtomicU32, Ordering};

use cortex_m::peripheral::syst::SystClkSource;
use cortex_m::peripheral::SYST;
use cortex_m_semihosting::{debug, hio};

pub struct Target {
    syst: SYST,
    out: Option<hio::HostStream>,
    painted_top: usize,
    painted_sp: usize,
}

impl core::fmt::Write for Target {
    fn write_str(&mut self, s: &str) -> core::fmt::Result {
        match self.out.as_mut() {
            Some(o) => o.write_str(s),
            None => Ok(()),
        }
    }
}

impl super::Platform for Target {
    fn ticks(&mut self) -> Option<u32> {
        Some(SYST::get_current())
    }
    fn long_ticks(&mut self) -> Option<u64> {
        loop {
            let before = WRAPS.load(Ordering::Acquire);
            let count = SYST::get_current();
            if WRAPS.load(Ordering::Acquire) == before {
                return Some(u64::from(before) << 24 | u64::from(0x00ff_ffff - count));
            }
        }
    }
    fn calibrate(&mut self) -> f64 {
        const LOOPS: u32 = 200_000;
        let t0 = SYST::get_current();
        // 2 instructions per iteration plus one: `subs`, `bne`.
        // SAFETY: a register-only countdown loop; no memory is touched.
        unsafe {
            core::arch::asm!(
                "2:",
                "subs {n}, {n}, #1",
                "bne 2b",
                n = inout(reg) LOOPS => _,
                options(nomem, nostack)
            );
        }
        let t1 = SYST::get_current();
        let ticks = super::elapsed(t0, t1).max(1);
        (2 * LOOPS as u64) as f64 / ticks as f64
    }

    fn double_precision_fpu(&mut self) -> bool {
        // CPUID's part number: 0xC27 is the Cortex-M7.
        // SAFETY: a read of CPUID's read-only base register, which every core has.
        let base = unsafe { (*cortex_m::peripheral::CPUID::PTR).base.read() };
        (base >> 4) & 0xFFF == 0xC27
    }

    fn paint_stack(&mut self) {
        let (low, sp) = (stack_floor(), cortex_m::register::msp::read() as usize);
        // Leave this function's own frame alone.
        let top = sp.saturating_sub(GUARD) & !3;
        let mut a = low;
        while a < top {
            // SAFETY: the words between the end of .bss/.uninit (the heap is unused) and
            // below the current stack pointer are free stack, not in use by anyone.
            unsafe { core::ptr::write_volatile(a as *mut u32, PAINT) };
            a += 4;
        }
        self.painted_top = top;
        self.painted_sp = sp;
    }

    fn stack_used(&mut self) -> Option<usize> {
        let mut a = stack_floor();
        while a < self.painted_top {
            // SAFETY: reads of the free stack words painted above.
            if unsafe { core::ptr::read_volatile(a as *const u32) } != PAINT {
                break;
            }
            a += 4;
        }
        // From the stack pointer at painting (an upper bound: the guard counts as used).
        Some(self.painted_sp - a)
    }
}

/// The stack pattern.
const PAINT: u32 = 0x5AC5_5AC5;
/// Bytes below the stack pointer left unpainted (the painting function's frame).
const GUARD: usize = 256;

/// The lowest address the stack can grow into: the start of the (unused) heap.
fn stack_floor() -> usize {
    extern "C" {
        static mut __sheap: u32;
    }
    // Only the address of the linker symbol is taken.
    (core::ptr::addr_of!(__sheap) as usize + 3) & !3
}

/// SysTick's wraps (every 2²⁴ ticks), for [`super::Platform::long_ticks`].
static WRAPS: AtomicU32 = AtomicU32::new(0);

#[cortex_m_rt::exception]
fn SysTick() {
    WRAPS.fetch_add(1, Ordering::AcqRel);
}

#[cortex_m_rt::entry]
fn main() -> ! {
    let mut cp = cortex_m::Peripherals::take().unwrap();
    cp.SYST.set_clock_source(SystClkSource::Core);
    cp.SYST.set_reload(0x00ff_ffff);
    cp.SYST.clear_current();
    // The wrap's exception: once per 671 M instructions, outside any per-set figure but
    // by chance.
    cp.SYST.enable_interrupt();
    cp.SYST.enable_counter();
    let mut t = Target {
        syst: cp.SYST,
        out: hio::hstdout().ok(),
        painted_top: 0,
        painted_sp: 0,
    };
    let _ = &t.syst;
    let code = super::run(&mut t);
    if code == 0 {
        debug::exit(debug::EXIT_SUCCESS);
    } else {
        debug::exit(debug::EXIT_FAILURE);
    }
    loop {
        cortex_m::asm::wfi();
    }
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    if let Ok(mut o) = hio::hstderr() {
        use core::fmt::Write;
        let _ = writeln!(o, "qemu-bench panicked: {info}");
    }
    debug::exit(debug::EXIT_FAILURE);
    loop {
        cortex_m::asm::wfi();
    }
}
