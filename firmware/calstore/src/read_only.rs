//! A flash opened for reading only: the boot path reads the newest record and never writes,
//! so it opens the store through this and the flash driver's program and erase code stays out
//! of an image that only boots (the boards' sizes: `docs/validation.md`, "Budgets"). A store that would repair or write through it gets [`ReadOnlyError::Refused`].

use embedded_storage_async::nor_flash::{
    ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash,
};

/// The flash `F`, reads only.
pub struct ReadOnly<F>(pub F);

/// A read failed, or a write or erase was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ReadOnlyError<E> {
    /// The flash's own read error.
    Read(E),
    /// A write or erase through a read-only flash.
    Refused,
}

impl<E: NorFlashError> NorFlashError for ReadOnlyError<E> {
    fn kind(&self) -> NorFlashErrorKind {
        match self {
            ReadOnlyError::Read(e) => e.kind(),
            ReadOnlyError::Refused => NorFlashErrorKind::Other,
        }
    }
}

impl<F: ReadNorFlash> ErrorType for ReadOnly<F> {
    type Error = ReadOnlyError<F::Error>;
}

impl<F: ReadNorFlash> ReadNorFlash for ReadOnly<F> {
    const READ_SIZE: usize = F::READ_SIZE;

    async fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Self::Error> {
        self.0
            .read(offset, bytes)
            .await
            .map_err(ReadOnlyError::Read)
    }

    fn capacity(&self) -> usize {
        self.0.capacity()
    }
}

impl<F: NorFlash> NorFlash for ReadOnly<F> {
    const WRITE_SIZE: usize = F::WRITE_SIZE;
    const ERASE_SIZE: usize = F::ERASE_SIZE;

    async fn erase(&mut self, _from: u32, _to: u32) -> Result<(), Self::Error> {
        Err(ReadOnlyError::Refused)
    }

    async fn write(&mut self, _offset: u32, _bytes: &[u8]) -> Result<(), Self::Error> {
        Err(ReadOnlyError::Refused)
    }
}
