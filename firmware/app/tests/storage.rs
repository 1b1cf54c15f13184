//! The storage task's commit (`storage::commit_next`: the next id, the record written, read
//! back) with power lost after every octet it programs or erases: the next boot finds the
//! previous calibration or the new one, whole, and a commit reported stored is the one it
//! finds.

use ballisto_fw::calstore::ram_flash::{Programming, RamFlash};
use ballisto_fw::calstore::store::{select_at_boot, CalibrationStore};
use ballisto_fw::config::tetra;
use ballisto_fw::storage::{commit_next, CommitReply};
use ballisto_link::CalibrationSource;
use futures::executor::block_on;

const SECTOR: usize = 4096;
/// Calibrations stored before the commit under test.
const PREFILL: u32 = 7;

/// The same calibration: every channel's position, noise, bias and scale equal, and its axis
/// to the 2 ulp of the re-normalisation on reading (`calstore::record`).
fn same<const N: usize>(
    a: &estimator_core::Arrangement<N>,
    b: &estimator_core::Arrangement<N>,
) -> bool {
    a.len() == b.len()
        && a.channels().iter().zip(b.channels()).all(|(x, y)| {
            x.position == y.position
                && x.noise == y.noise
                && x.bias == y.bias
                && x.scale == y.scale
                && (0..3).all(|k| (x.axis[k] - y.axis[k]).abs() < 1e-15)
        })
}
type Flash<'a> = RamFlash<'a, SECTOR, 32>;

#[test]
fn a_commit_cut_at_any_octet_leaves_the_old_calibration_or_the_new_one() {
    let nominal = tetra().arrangement;
    // Calibrations already stored, so many that the next commit erases a sector to make room.
    let mut base = vec![0xFFu8; 2 * SECTOR];
    let mut erases = [0u32; 2];
    let range = 0..(2 * SECTOR) as u32;
    let mut previous = nominal.clone();
    {
        let flash = Flash::new(&mut base, &mut erases, Programming::WordOnce);
        let mut store = CalibrationStore::new(flash, range.clone()).unwrap();
        for k in 0..PREFILL {
            let mut a = nominal.clone();
            a.set_calibration(0, 0.01 * f64::from(k), 1.0).unwrap();
            assert!(
                matches!(block_on(commit_next(&mut store, &a)), CommitReply::Stored { id, .. } if id == k + 1)
            );
            previous = a;
        }
    }
    let mut next = nominal.clone();
    next.set_calibration(0, 0.5, 1.001).unwrap();
    // How many octets the commit touches when nothing is cut.
    let before = erases;
    let (full, erased) = {
        let mut mem = base.clone();
        let mut e = before;
        let flash = Flash::new(&mut mem, &mut e, Programming::WordOnce);
        let mut store = CalibrationStore::new(flash, range.clone()).unwrap();
        let reply = block_on(commit_next(&mut store, &next));
        assert!(matches!(reply, CommitReply::Stored { id, .. } if id == PREFILL + 1));
        let flash = store.into_flash();
        (flash.touched(), flash.erase_counts() != before)
    };
    assert!(erased, "the commit under test erases a sector");
    let (mut old, mut new, mut stored) = (0, 0, 0);
    for cut in 0..full {
        let mut mem = base.clone();
        let mut e = [0u32; 2];
        let mut flash = Flash::new(&mut mem, &mut e, Programming::WordOnce);
        flash.cut_power_after(cut);
        let mut store = CalibrationStore::new(flash, range.clone()).unwrap();
        let reply = block_on(commit_next(&mut store, &next));
        let mut flash = store.into_flash();
        flash.power_on();
        let mut store = CalibrationStore::new(flash, range.clone()).unwrap();
        let (arrangement, id, why) = block_on(select_at_boot(&mut store, &nominal));
        assert!(why.is_none(), "cut {cut}: {why:?}");
        assert_eq!(id.source, CalibrationSource::Flash);
        match id.id {
            PREFILL => {
                assert!(same(&arrangement, &previous), "cut {cut}");
                assert!(
                    !matches!(reply, CommitReply::Stored { .. }),
                    "cut {cut}: reported stored"
                );
                old += 1;
            }
            n if n == PREFILL + 1 => {
                assert!(same(&arrangement, &next), "cut {cut}");
                new += 1;
            }
            other => panic!("cut {cut}: calibration {other}"),
        }
        stored += usize::from(matches!(reply, CommitReply::Stored { .. }));
    }
    println!(
        "{full} cuts (a sector erase among them): the next boot found the previous calibration {old} times, the new one {new} (reported stored {stored})"
    );
    assert_eq!(old + new, full as usize);
}
