//! Where a calibrated arrangement's frame sits against the true one, and the errors of an
//! estimate seen in that frame: what calibration cannot see (the common translation always,
//! the rotation and size without a reference) is held by convention, so a calibrated
//! estimate is that of the body seen in the calibrated frame.

use std::fs::File;
use std::io::{BufRead, BufReader};
use std::path::Path;

use ballisto_config::arrangement_file::ArrangementFile;
use nalgebra::{DMatrix, DVector, Matrix3, Vector3};

/// Where the calibrated file's frame sits against the true one: the common rotation of the
/// axes (`n_c = n_t + δ × n_t`, least squares), then the common translation and size of the
/// positions (`R_c = R_t + δ × R_t + t + s R_t`). What calibration cannot see (the
/// translation always, the rotation and size without a reference) is held by convention, so
/// the estimate is that of a body seen in this frame.
pub struct Frame {
    /// Common rotation of the axes (rad, small vector).
    pub rotation: Vector3<f64>,
    /// Common translation of the positions (m).
    pub translation: Vector3<f64>,
    /// Common relative size of the positions.
    pub size: f64,
    /// The axes' rotation against the lever arms': the axes' common rotation minus the one
    /// the positions show when they are fitted with a rotation of their own.
    pub relative_rotation: Vector3<f64>,
}

pub fn frame_of(calibrated: &Path, truth: &Path) -> Frame {
    let read = |p: &Path| {
        ArrangementFile::read(p)
            .unwrap()
            .expanded_channels("f")
            .unwrap()
    };
    let (c, t) = (read(calibrated), read(truth));
    let mut n = DMatrix::zeros(3 * c.len(), 3);
    let mut rhs = DVector::zeros(3 * c.len());
    for (i, (a, b)) in c.iter().zip(t.iter()).enumerate() {
        assert_eq!(a.name, b.name);
        let (na, nb) = (
            Vector3::from(a.axis).normalize(),
            Vector3::from(b.axis).normalize(),
        );
        // δ × n = −[n×] δ
        n.view_mut((3 * i, 0), (3, 3))
            .copy_from(&(-nb.cross_matrix()));
        rhs.rows_mut(3 * i, 3).copy_from(&(na - nb));
    }
    let rotation: Vector3<f64> = n
        .svd(true, true)
        .solve(&rhs, 1e-12)
        .unwrap()
        .fixed_rows::<3>(0)
        .into();
    let mut m = DMatrix::zeros(3 * c.len(), 4);
    let mut rhs = DVector::zeros(3 * c.len());
    for (i, (a, b)) in c.iter().zip(t.iter()).enumerate() {
        let (ra, rb) = (Vector3::from(a.position), Vector3::from(b.position));
        m.view_mut((3 * i, 0), (3, 3))
            .copy_from(&Matrix3::identity());
        m.view_mut((3 * i, 3), (3, 1)).copy_from(&rb);
        rhs.rows_mut(3 * i, 3)
            .copy_from(&(ra - rb - rotation.cross(&rb)));
    }
    let x = m.svd(true, true).solve(&rhs, 1e-12).unwrap();
    // The positions' own rotation δ_p (with translation and size): R_c − R_t = δ_p × R_t
    // + t + s R_t.
    let mut mp = DMatrix::zeros(3 * c.len(), 7);
    let mut rhs = DVector::zeros(3 * c.len());
    for (i, (a, b)) in c.iter().zip(t.iter()).enumerate() {
        let (ra, rb) = (Vector3::from(a.position), Vector3::from(b.position));
        mp.view_mut((3 * i, 0), (3, 3))
            .copy_from(&(-rb.cross_matrix()));
        mp.view_mut((3 * i, 3), (3, 3))
            .copy_from(&Matrix3::identity());
        mp.view_mut((3 * i, 6), (3, 1)).copy_from(&rb);
        rhs.rows_mut(3 * i, 3).copy_from(&(ra - rb));
    }
    let xp = mp.svd(true, true).solve(&rhs, 1e-12).unwrap();
    Frame {
        rotation,
        translation: Vector3::new(x[0], x[1], x[2]),
        size: x[3],
        relative_rotation: rotation - Vector3::new(xp[0], xp[1], xp[2]),
    }
}

/// RMS errors of σ0, Ω′ and Ω against the truth seen in `frame`: σ0 at the point the frame
/// calls the origin (the true point `−t`: `σ0 − Ω′ × t − Ω × (Ω × t)`), every vector turned
/// by δ, Ω′ and Ω scaled as the size scales `{Ω′}` and `{Ω}²`. Reads `run`'s `truth.csv` and
/// the estimates file row by row (hours of records at 100 Hz do not fit in memory whole).
pub fn errors_in(run: &Path, estimates: &str, frame: &Frame) -> [f64; 3] {
    let open = |p: &Path| {
        let mut lines = BufReader::new(File::open(p).unwrap()).lines();
        let header: Vec<String> = lines
            .next()
            .unwrap()
            .unwrap()
            .split(',')
            .map(String::from)
            .collect();
        (header, lines)
    };
    let (th, truth) = open(&run.join("truth.csv"));
    let (eh, est) = open(&run.join(estimates));
    let columns = |h: &[String], name: &str| -> [usize; 3] {
        ["x", "y", "z"].map(|a| h.iter().position(|x| *x == format!("{name}_{a}")).unwrap())
    };
    let names = ["sigma0", "domega", "omega"];
    let (tc, ec) = (
        names.map(|n| columns(&th, n)),
        names.map(|n| columns(&eh, n)),
    );
    let vector = |r: &[f64], c: [usize; 3]| Vector3::new(r[c[0]], r[c[1]], r[c[2]]);
    let parse = |l: String| -> Vec<f64> {
        l.split(',')
            .map(|v| v.parse().unwrap_or(f64::NAN))
            .collect()
    };
    let turn = |v: Vector3<f64>| v + frame.rotation.cross(&v);
    let t = frame.translation;
    let mut sums = [0.0; 3];
    let mut rows = 0usize;
    for (a, b) in truth.zip(est) {
        let (a, b) = (parse(a.unwrap()), parse(b.unwrap()));
        let (w, dw) = (vector(&a, tc[2]), vector(&a, tc[1]));
        let s0 = vector(&a, tc[0]) - dw.cross(&t) - w.cross(&w.cross(&t));
        let truth = [
            turn(s0),
            turn(dw) / (1.0 + frame.size),
            turn(w) / (1.0 + frame.size).sqrt(),
        ];
        for k in 0..3 {
            sums[k] += (vector(&b, ec[k]) - truth[k]).norm_squared();
        }
        rows += 1;
    }
    sums.map(|v| (v / rows as f64).sqrt())
}
