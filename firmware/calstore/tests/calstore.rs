//! Calibration records in flash that survive power loss.
//!
//! - A commit cut by power loss at every octet it programs or erases (including the sector
//!   erases and moves of `sequential-storage`'s garbage collection) leaves the old or the new
//!   record in use at the next boot — never a part of one, never an error — and the store
//!   takes the next commit.
//! - Ids only grow; at boot the stored calibration is used if whole and for the configured
//!   channels, else the built-in one, and the identity (source, id, CRC) says which.
//! - Wear over 10⁴ updates on the STM32H743's layout (two 128 KiB sectors, 32-octet flash
//!   words), printed.

use ballisto_calstore::{
    select_at_boot, CalibrationRecord, CalibrationSource, CalibrationStore, NotUsed, Programming,
    RamFlash, StoreError, MAX_RECORD,
};
use ballisto_link::ids::MAX_CHANNELS;
use estimator_core::{Arrangement, FrameUncertainty};
use futures::executor::block_on;

/// A calibration `id` of `n` channels whose numbers depend on the id.
fn record(id: u32, n: usize) -> CalibrationRecord {
    let mut a = Arrangement::new();
    let v = f64::from(id);
    for i in 0..n {
        let x = i as f64;
        a.push(
            [0.01 * x + 1e-5 * v, -0.02 * x, 0.1],
            [1.0, 0.01 * x, -0.02 + 1e-4 * v],
            1e-3,
        )
        .unwrap();
        a.set_calibration(i, 0.02 - 0.001 * x + 1e-4 * v, 1.0 + 0.001 * x)
            .unwrap();
    }
    a.set_frame_uncertainty(FrameUncertainty {
        rotation: 1e-4 * v,
        ..FrameUncertainty::default()
    })
    .unwrap();
    CalibrationRecord { id, arrangement: a }
}

/// What a record reads back as (the arrangement normalises the axes again on reading).
fn as_read(r: &CalibrationRecord) -> CalibrationRecord {
    let mut buf = [0u8; MAX_RECORD];
    let len = r.encode(&mut buf).unwrap();
    CalibrationRecord::decode(&buf[..len]).unwrap()
}

const SECTOR: usize = 4096;
const WORD: usize = 32;
const SECTORS: usize = 4;

type Flash<'a> = RamFlash<'a, SECTOR, WORD>;

fn store<'a>(
    mem: &'a mut [u8],
    erases: &'a mut [u32],
    p: Programming,
) -> CalibrationStore<Flash<'a>> {
    let len = mem.len() as u32;
    CalibrationStore::new(RamFlash::new(mem, erases, p), 0..len).unwrap()
}

/// The newest record's id, or a description of what went wrong.
fn newest_id(mem: &mut [u8], p: Programming) -> Result<Option<(u32, CalibrationRecord)>, String> {
    let mut erases = [0u32; SECTORS];
    let mut s = store(mem, &mut erases, p);
    match block_on(s.newest()) {
        Ok(Some((r, _))) => Ok(Some((r.id, r))),
        Ok(None) => Ok(None),
        Err(e) => Err(format!("{e}")),
    }
}

/// Commits, refusals and the choice at boot.
#[test]
fn commits_grow_the_id_and_boot_takes_the_newest_whole_record() {
    let mut mem = vec![0u8; SECTORS * SECTOR];
    let mut erases = [0u32; SECTORS];
    let mut flash = RamFlash::<SECTOR, WORD>::new(&mut mem, &mut erases, Programming::WordOnce);
    flash.erase_all();
    let mut s = CalibrationStore::new(flash, 0..(SECTORS * SECTOR) as u32).unwrap();
    let builtin = record(0, 12).arrangement;

    // Empty: the built-in arrangement, and why.
    let (a, active, why) = block_on(select_at_boot(&mut s, &builtin));
    assert_eq!(a, builtin);
    assert_eq!(active.source, CalibrationSource::Builtin);
    assert_eq!((active.id, active.crc), (0, 0));
    assert!(matches!(why, Some(NotUsed::Empty)));

    // Stored: used, with its id and the CRC its record carries.
    let r1 = record(1, 12);
    block_on(s.commit(&r1)).unwrap();
    let (a, active, why) = block_on(select_at_boot(&mut s, &builtin));
    assert!(why.is_none());
    assert_eq!(a, as_read(&r1).arrangement);
    assert_eq!(active.source, CalibrationSource::Flash);
    assert_eq!(active.id, 1);
    let mut buf = [0u8; MAX_RECORD];
    let len = r1.encode(&mut buf).unwrap();
    assert_eq!(Some(active.crc), CalibrationRecord::stored_crc(&buf[..len]));

    // An id that is not newer is refused, and nothing changes.
    for id in [1, 0] {
        let e = block_on(s.commit(&record(id, 12))).unwrap_err();
        assert!(
            matches!(e, StoreError::IdNotNewer { stored: 1, offered } if offered == id)
                || matches!(e, StoreError::Unencodable),
            "{e}"
        );
    }
    assert_eq!(block_on(s.newest()).unwrap().unwrap().0.id, 1);

    // Newer ids replace it; a record for another channel count is not used at boot.
    block_on(s.commit(&record(5, 12))).unwrap();
    assert_eq!(block_on(s.newest()).unwrap().unwrap().0.id, 5);
    block_on(s.commit(&record(6, 9))).unwrap();
    let (a, active, why) = block_on(select_at_boot(&mut s, &builtin));
    assert_eq!(a, builtin);
    assert_eq!(active.source, CalibrationSource::Builtin);
    assert!(matches!(
        why,
        Some(NotUsed::Channels {
            stored: 9,
            configured: 12
        })
    ));
}

/// A commit cut by power loss at every octet: the next boot finds the old record or the new
/// one, whole, and the store takes the next commit. Over twelve successive commits of the
/// largest record (24 channels, 1 776 octets) on four 4 KiB sectors, so that the cuts also
/// fall in the sector erases and moves of the garbage collection; for both kinds of
/// programming (the H7's whole-word, write-once programming and a byte-programmable NOR).
fn power_cut_at_every_octet(p: Programming) {
    let n = MAX_CHANNELS;
    let mut base = vec![0u8; SECTORS * SECTOR];
    {
        let mut erases = [0u32; SECTORS];
        RamFlash::<SECTOR, WORD>::new(&mut base, &mut erases, p).erase_all();
    }
    let (mut trials, mut kept_old, mut took_new) = (0u64, 0u64, 0u64);
    let mut erase_cuts = 0u64;
    for k in 0..12u32 {
        // The octets the next commit programs and erases, uncut.
        let (total, erased) = {
            let mut mem = base.clone();
            let mut erases = [0u32; SECTORS];
            let mut s = store(&mut mem, &mut erases, p);
            block_on(s.commit(&record(k + 1, n))).unwrap();
            let flash = s.into_flash();
            (flash.touched(), flash.erase_counts().iter().sum::<u32>())
        };
        if erased > 0 {
            erase_cuts += total;
        }
        for cut in 0..total {
            let mut mem = base.clone();
            let mut erases = [0u32; SECTORS];
            {
                let mut flash = RamFlash::<SECTOR, WORD>::new(&mut mem, &mut erases, p);
                flash.cut_power_after(cut);
                let mut s = CalibrationStore::new(flash, 0..(SECTORS * SECTOR) as u32).unwrap();
                assert!(
                    block_on(s.commit(&record(k + 1, n))).is_err(),
                    "{p:?}: k {k}, cut {cut}"
                );
            }
            // Reboot: power is back (a new flash over the same memory).
            match newest_id(&mut mem, p) {
                Ok(Some((id, r))) if id == k + 1 => {
                    assert_eq!(r, as_read(&record(k + 1, n)));
                    took_new += 1;
                }
                Ok(Some((id, r))) if id == k && k > 0 => {
                    assert_eq!(r, as_read(&record(k, n)));
                    kept_old += 1;
                }
                Ok(None) if k == 0 => kept_old += 1,
                other => panic!("{p:?}: commit {k}, cut at octet {cut} of {total}: {other:?}"),
            }
            // The store takes the next commit.
            let mut erases = [0u32; SECTORS];
            let mut s = store(&mut mem, &mut erases, p);
            block_on(s.commit(&record(k + 2, n))).unwrap_or_else(|e| {
                panic!("{p:?}: commit {k}, cut at octet {cut} of {total}: next commit failed: {e}")
            });
            assert_eq!(block_on(s.newest()).unwrap().unwrap().0.id, k + 2);
            trials += 1;
        }
        // The commit, uncut, becomes the base of the next.
        let mut erases = [0u32; SECTORS];
        let mut s = store(&mut base, &mut erases, p);
        block_on(s.commit(&record(k + 1, n))).unwrap();
    }
    println!(
        "{p:?}: power cut at every octet of 12 commits: {trials} cuts ({erase_cuts} in commits \
         that erase a sector); the old record kept {kept_old}, the new one taken {took_new}; \
         never a part of one, and the next commit always taken"
    );
    // Both outcomes occur with octet-wise programming; with whole words the commit's last
    // word completes it, so every cut before it keeps the old record.
    assert!(kept_old > 0 && erase_cuts > 0);
    assert_eq!(took_new > 0, p == Programming::ByteNor);
}

#[test]
fn power_cut_at_every_octet_h7_words() {
    power_cut_at_every_octet(Programming::WordOnce);
}

#[test]
fn power_cut_at_every_octet_byte_nor() {
    power_cut_at_every_octet(Programming::ByteNor);
}

/// 10⁴ updates on the STM32H743's layout for the store: two 128 KiB sectors, 32-octet words,
/// records of 24 channels. Prints the erase count per sector and the updates the sectors'
/// endurance (10 000 cycles, datasheet) allows.
#[test]
fn wear_over_ten_thousand_updates() {
    const H7_SECTOR: usize = 128 * 1024;
    let updates = 10_000u32;
    let mut mem = vec![0u8; 2 * H7_SECTOR];
    let mut erases = [0u32; 2];
    let mut flash = RamFlash::<H7_SECTOR, 32>::new(&mut mem, &mut erases, Programming::WordOnce);
    flash.erase_all();
    let mut s = CalibrationStore::new(flash, 0..(2 * H7_SECTOR) as u32).unwrap();
    for id in 1..=updates {
        block_on(s.commit(&record(id, MAX_CHANNELS))).unwrap();
    }
    assert_eq!(block_on(s.newest()).unwrap().unwrap().0.id, updates);
    let flash = s.into_flash();
    let counts = flash.erase_counts().to_vec();
    let max = *counts.iter().max().unwrap();
    let per_update = f64::from(max) / f64::from(updates);
    println!(
        "wear: {updates} updates of a 24-channel record on 2 × 128 KiB sectors: erases per \
         sector {counts:?}; at 10 000 cycles per sector the store takes about {:.0} updates",
        10_000.0 / per_update
    );
    // Even wear: the two sectors within one erase of each other, and well below one erase
    // per update.
    assert!(counts.iter().max().unwrap() - counts.iter().min().unwrap() <= 1);
    assert!(per_update < 0.05, "{per_update}");
}

/// The boot path's read-only flash: the newest record reads through it; a commit through it is
/// refused by the flash (nothing is written: the stored record stays the newest).
#[test]
fn read_only_flash_reads_and_refuses_to_write() {
    use ballisto_calstore::{ReadOnly, ReadOnlyError};
    let mut mem = vec![0u8; SECTORS * SECTOR];
    {
        let mut erases = [0u32; SECTORS];
        let mut flash = RamFlash::<SECTOR, WORD>::new(&mut mem, &mut erases, Programming::WordOnce);
        flash.erase_all();
        let mut s = CalibrationStore::new(flash, 0..(SECTORS * SECTOR) as u32).unwrap();
        block_on(s.commit(&record(4, 12))).unwrap();
    }
    let before = mem.clone();
    let mut erases = [0u32; SECTORS];
    let flash = RamFlash::<SECTOR, WORD>::new(&mut mem, &mut erases, Programming::WordOnce);
    let mut s = CalibrationStore::new(ReadOnly(flash), 0..(SECTORS * SECTOR) as u32).unwrap();
    assert_eq!(block_on(s.newest()).unwrap().unwrap().0.id, 4);
    let e = block_on(s.commit(&record(5, 12))).unwrap_err();
    assert!(
        matches!(
            e,
            StoreError::Flash(sequential_storage::Error::Storage {
                value: ReadOnlyError::Refused,
                ..
            })
        ),
        "{e:?}"
    );
    assert_eq!(block_on(s.newest()).unwrap().unwrap().0.id, 4);
    let _ = s.into_flash();
    assert_eq!(mem, before, "nothing written");
}
