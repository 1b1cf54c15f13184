//! A NOR flash in RAM, behind the `embedded-storage-async` traits: the QEMU board's stand-in
//! for the STM32H743's flash, and the host tests' flash that loses power at any chosen byte.
//!
//! Erase sets a sector to `0xFF`. Programming comes in two kinds ([`Programming`]):
//!
//! - [`Programming::WordOnce`], the STM32H743's: a flash word (`WORD` octets, 32 on the H7) is
//!   programmed whole and only once after an erase (its ECC cannot be rewritten: this refuses
//!   it instead of corrupting), and a power cut falls between words;
//! - [`Programming::ByteNor`], a byte-programmable NOR (an external SPI NOR, the older STM32
//!   families): a cut can fall after any octet, and programming may clear more bits of a
//!   programmed word (never set them) — `sequential-storage`'s own model.
//!
//! Power loss: with a budget of `k` octets, the operation in progress stops after `k` octets
//! of programming or erasing (an erase clears the sector from its start), returns
//! [`RamFlashError::PowerLost`] and every later operation fails until [`RamFlash::power_on`].
//! Not modelled: the H7's ECC error on reading a word whose programming or erase was cut (here
//! a word is programmed whole or not at all, and a cut erase leaves the sector partly erased).

use embedded_storage_async::nor_flash::{
    ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash,
};

/// How a word is programmed (module documentation).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Programming {
    /// Whole words, once per erase; cuts between words (the STM32H743).
    WordOnce,
    /// Octet by octet, bits cleared only; cuts after any octet.
    ByteNor,
}

/// Why an operation failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RamFlashError {
    /// Offset or length not a multiple of the word (or sector) size.
    NotAligned,
    /// Beyond the flash.
    OutOfBounds,
    /// Programming a word that is not erased ([`Programming::WordOnce`]), or setting a bit
    /// that is clear ([`Programming::ByteNor`]).
    NotErased,
    /// Power was lost during this operation, or before it.
    PowerLost,
}

impl NorFlashError for RamFlashError {
    fn kind(&self) -> NorFlashErrorKind {
        match self {
            RamFlashError::NotAligned => NorFlashErrorKind::NotAligned,
            RamFlashError::OutOfBounds => NorFlashErrorKind::OutOfBounds,
            RamFlashError::NotErased | RamFlashError::PowerLost => NorFlashErrorKind::Other,
        }
    }
}

/// `mem.len()` octets of flash in sectors of `SECTOR` octets, programmed in words of `WORD`.
pub struct RamFlash<'a, const SECTOR: usize, const WORD: usize> {
    mem: &'a mut [u8],
    /// Erase count per sector.
    erases: &'a mut [u32],
    /// Octets that can still be programmed or erased before power is lost (`None`: no limit).
    budget: Option<u64>,
    /// Power was lost and has not come back.
    off: bool,
    /// Octets programmed and erased so far.
    touched: u64,
    programming: Programming,
}

impl<'a, const SECTOR: usize, const WORD: usize> RamFlash<'a, SECTOR, WORD> {
    /// A flash over `mem` (a whole number of sectors, as found: a fresh board's RAM is not
    /// erased flash, call [`RamFlash::erase_all`]) counting erases per sector in `erases`
    /// (`mem.len() / SECTOR` entries, or fewer: sectors beyond are not counted).
    pub fn new(mem: &'a mut [u8], erases: &'a mut [u32], programming: Programming) -> Self {
        RamFlash {
            mem,
            erases,
            budget: None,
            off: false,
            touched: 0,
            programming,
        }
    }

    /// Sets every octet to `0xFF` (a factory-erased part; not counted as wear).
    pub fn erase_all(&mut self) {
        self.mem.fill(0xFF);
    }

    /// Power will be lost after `octets` more octets of programming or erasing.
    pub fn cut_power_after(&mut self, octets: u64) {
        self.budget = Some(octets);
    }

    /// Power is back (a reset): operations work again, with no budget.
    pub fn power_on(&mut self) {
        self.off = false;
        self.budget = None;
    }

    /// Octets programmed and erased since creation.
    pub fn touched(&self) -> u64 {
        self.touched
    }

    /// Erase count of every sector.
    pub fn erase_counts(&self) -> &[u32] {
        self.erases
    }

    /// Takes one octet of the power budget; false when power is lost now.
    fn spend(&mut self) -> bool {
        if let Some(b) = self.budget.as_mut() {
            if *b == 0 {
                self.off = true;
                return false;
            }
            *b -= 1;
        }
        self.touched += 1;
        true
    }

    fn range(
        &self,
        offset: u32,
        len: usize,
        align: usize,
    ) -> Result<core::ops::Range<usize>, RamFlashError> {
        let start = offset as usize;
        if !start.is_multiple_of(align) || !len.is_multiple_of(align) {
            return Err(RamFlashError::NotAligned);
        }
        let end = start.checked_add(len).ok_or(RamFlashError::OutOfBounds)?;
        if end > self.mem.len() {
            return Err(RamFlashError::OutOfBounds);
        }
        Ok(start..end)
    }
}

impl<const SECTOR: usize, const WORD: usize> ErrorType for RamFlash<'_, SECTOR, WORD> {
    type Error = RamFlashError;
}

impl<const SECTOR: usize, const WORD: usize> ReadNorFlash for RamFlash<'_, SECTOR, WORD> {
    const READ_SIZE: usize = 1;

    async fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Self::Error> {
        if self.off {
            return Err(RamFlashError::PowerLost);
        }
        let r = self.range(offset, bytes.len(), 1)?;
        bytes.copy_from_slice(&self.mem[r]);
        Ok(())
    }

    fn capacity(&self) -> usize {
        self.mem.len()
    }
}

impl<const SECTOR: usize, const WORD: usize> NorFlash for RamFlash<'_, SECTOR, WORD> {
    const WRITE_SIZE: usize = WORD;
    const ERASE_SIZE: usize = SECTOR;

    async fn erase(&mut self, from: u32, to: u32) -> Result<(), Self::Error> {
        if self.off {
            return Err(RamFlashError::PowerLost);
        }
        let len = (to as usize)
            .checked_sub(from as usize)
            .ok_or(RamFlashError::OutOfBounds)?;
        let r = self.range(from, len, SECTOR)?;
        for sector in r.clone().step_by(SECTOR) {
            if let Some(c) = self.erases.get_mut(sector / SECTOR) {
                *c += 1;
            }
            for i in sector..sector + SECTOR {
                if !self.spend() {
                    return Err(RamFlashError::PowerLost);
                }
                self.mem[i] = 0xFF;
            }
        }
        Ok(())
    }

    async fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Self::Error> {
        if self.off {
            return Err(RamFlashError::PowerLost);
        }
        let r = self.range(offset, bytes.len(), WORD)?;
        let old = &self.mem[r.clone()];
        let refused = match self.programming {
            Programming::WordOnce => old.iter().any(|&b| b != 0xFF),
            Programming::ByteNor => old.iter().zip(bytes).any(|(&o, &b)| b & !o != 0),
        };
        if refused {
            return Err(RamFlashError::NotErased);
        }
        match self.programming {
            Programming::WordOnce => {
                for (w, word) in r.step_by(WORD).zip(bytes.chunks(WORD)) {
                    // The whole word's budget first: a cut leaves it unprogrammed.
                    if let Some(b) = self.budget {
                        if b < WORD as u64 {
                            self.off = true;
                            return Err(RamFlashError::PowerLost);
                        }
                        self.budget = Some(b - WORD as u64);
                    }
                    self.touched += WORD as u64;
                    self.mem[w..w + WORD].copy_from_slice(word);
                }
            }
            Programming::ByteNor => {
                for (i, &b) in r.zip(bytes.iter()) {
                    if !self.spend() {
                        return Err(RamFlashError::PowerLost);
                    }
                    self.mem[i] &= b;
                }
            }
        }
        Ok(())
    }
}
