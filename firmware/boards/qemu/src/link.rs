//! The QEMU board's telemetry link: every frame goes to the boot's file on the host, through
//! semihosting (the run's record, which the tests decode), and to UART0 — mps2-an386's CMSDK
//! APB UART, QEMU's first serial port — as the STM32H743 board's frames go to its USART and
//! the ST-LINK's virtual serial port. With `-serial pty` a ground tool follows the board live
//! (`scripts/qemu-live.sh`, `ballisto capture`); with `-serial none` the UART drains at once.

use embedded_io_async::{ErrorKind, ErrorType, Write};

use ballisto_fw::time::{Nanos, TimeBase};
use cortex_m_semihosting::syscall;

/// A host file opened through semihosting.
pub struct HostFile(usize);

impl HostFile {
    /// Creates (or truncates) the host file `name`, which must end with a NUL.
    pub fn create(name: &str) -> Option<Self> {
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

/// UART0 of mps2-an386: the CMSDK APB UART at 0x4000_4000.
const UART0: usize = 0x4000_4000;
const UART_DATA: usize = UART0;
const UART_STATE: usize = UART0 + 0x04;
const UART_CTRL: usize = UART0 + 0x08;
const UART_BAUDDIV: usize = UART0 + 0x10;
/// STATE: the transmit holding register is full.
const TX_FULL: u32 = 1;
/// CTRL: transmitter enabled.
const TX_ENABLE: u32 = 1;
/// 25 MHz / 921 600 baud, the STM32H743 board's link rate (QEMU sends as fast as its host side
/// takes the bytes; the divider must only be valid, ≥ 16).
const BAUD_DIVIDER: u32 = 27;
/// How long one octet may wait for a host side that does not read (a terminal opened and
/// not read): then the UART is given up for the boot, and the file keeps the record.
const STALL: Nanos = 100_000_000;
/// How often a full transmitter is looked at again (the time base's resolution).
const RETRY: Nanos = 1_000_000;

/// The transmitter of UART0, waiting on the time base (not spinning) while the host side is
/// full: the tasks below the telemetry keep running.
pub struct Uart<T> {
    time: T,
    /// The host side stopped taking octets for [`STALL`]: nothing more is sent this boot.
    given_up: bool,
}

impl<T: TimeBase> Uart<T> {
    /// Enables the transmitter.
    pub fn enable(time: T) -> Self {
        // SAFETY: UART0's registers, used by nothing else.
        unsafe {
            (UART_BAUDDIV as *mut u32).write_volatile(BAUD_DIVIDER);
            (UART_CTRL as *mut u32).write_volatile(TX_ENABLE);
        }
        Uart {
            time,
            given_up: false,
        }
    }

    async fn put(&mut self, octet: u8) -> Result<(), ErrorKind> {
        let since = self.time.now();
        // SAFETY: as in `enable`.
        while unsafe { (UART_STATE as *const u32).read_volatile() } & TX_FULL != 0 {
            let now = self.time.now();
            if now - since > STALL {
                self.given_up = true;
                return Err(ErrorKind::TimedOut);
            }
            self.time.wait_until(now + RETRY).await;
        }
        // SAFETY: as in `enable`.
        unsafe { (UART_DATA as *mut u32).write_volatile(u32::from(octet)) };
        Ok(())
    }
}

/// The board's link: the host file, then UART0.
pub struct BoardLink<T> {
    /// The record on the host.
    pub file: HostFile,
    /// The live link.
    pub uart: Uart<T>,
}

impl<T> ErrorType for BoardLink<T> {
    type Error = ErrorKind;
}

impl<T: TimeBase> Write for BoardLink<T> {
    /// The whole of `buf` to the file, then to the UART. A file that fails is an error (the
    /// packet is counted lost); a UART that stalls is one the first time (that packet is lost
    /// to the live link, which the board reports at its end) and skipped after.
    async fn write(&mut self, buf: &[u8]) -> Result<usize, ErrorKind> {
        self.file.write_all(buf).await?;
        if !self.uart.given_up {
            for &octet in buf {
                self.uart.put(octet).await?;
            }
        }
        Ok(buf.len())
    }

    async fn flush(&mut self) -> Result<(), ErrorKind> {
        self.file.flush().await
    }
}
