//! Which model an arrangement is estimated with when none is asked for — by `ballisto`, by the
//! host simulator's firmware and by a board built from the file: the
//! file's, unless model G cannot resolve the field on this arrangement. Model G estimates
//! the field's diagonal `d` from the channels' lever arms; on a nearly flat board (the
//! real MIMU4444 array is 2 mm thick) `d_z` is barely observable and model G's Ω is an
//! order worse than model F's (Γ known: 0 on the ground, negligible against the noise in
//! orbit).

use crate::arrangement_file::LoadedArrangement;
use estimator_core::Model;
use nalgebra::{DMatrix, DVector};

/// Model G is used only if it resolves every component of the field's diagonal to this
/// standard deviation per sample (s⁻²): the centripetal term of 1 rad/s.
pub const MAX_DIAGONAL_SD: f64 = 1.0;

/// The per-sample standard deviation of model G's field diagonal `d` (paper eq. 10's last
/// three columns) on this arrangement with its declared noise; `None` if model G cannot be
/// solved at all (fewer than 12 channels or a singular design).
pub fn model_g_diagonal_sd(loaded: &LoadedArrangement) -> Option<[f64; 3]> {
    let chans = loaded.arrangement.channels();
    if chans.len() < Model::General.min_channels() {
        return None;
    }
    let mut normal = DMatrix::<f64>::zeros(9, 9);
    for c in chans {
        let h = DVector::from_column_slice(&c.design_row());
        normal += &h * h.transpose() / (c.noise * c.noise);
    }
    let cov = normal.try_inverse()?;
    Some([6, 7, 8].map(|k| cov[(k, k)].max(0.0).sqrt()))
}

/// The model to use: `asked` (the command line) if given; else free-float where the file asks
/// for it or model G cannot be used or resolves the field's diagonal worse than
/// [`MAX_DIAGONAL_SD`]; else general. The second value says why, when the file's model was
/// overridden. A file that names model G on an arrangement that cannot carry it at all (fewer
/// than 12 channels, or a singular design) is an error naming the `file`: an explicit request
/// that cannot be honoured is not silently replaced.
pub fn recommend(
    asked: Option<Model>,
    loaded: &LoadedArrangement,
    file: &std::path::Path,
) -> Result<(Model, Option<String>), String> {
    if let Some(m) = asked {
        return Ok((m, None));
    }
    if loaded.model == Some(Model::FreeFloat) {
        return Ok((Model::FreeFloat, None));
    }
    Ok(match model_g_diagonal_sd(loaded) {
        Some(sd) if sd.iter().all(|v| *v <= MAX_DIAGONAL_SD) => (Model::General, None),
        Some(sd) => (
            Model::FreeFloat,
            Some(format!(
                "using model free-float: model general would resolve the field's diagonal only to {:.2}, {:.2}, {:.2} 1/s^2 per sample here (--model general insists)",
                sd[0], sd[1], sd[2]
            )),
        ),
        None if loaded.model == Some(Model::General) => {
            return Err(format!(
                "{}: model = \"general\" needs at least {} channels in a non-singular layout, this arrangement has {}: name model = \"free-float\" (or leave the key out to let ballisto choose)",
                file.display(),
                Model::General.min_channels(),
                loaded.names.len()
            ))
        }
        None => (
            Model::FreeFloat,
            Some("using model free-float: model general cannot be solved on this arrangement (fewer than 12 channels or a singular design)".into()),
        ),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::arrangement_file::ArrangementFile;

    /// Four tri-axial parts at (±a, ±a, ±h) (two on top, two underneath), noise 0.035.
    fn board(a: f64, h: f64) -> LoadedArrangement {
        let mut text = String::from("model = \"general\"\n");
        for (i, (x, y, z)) in [
            (1.0, 1.0, 1.0),
            (-1.0, 1.0, -1.0),
            (1.0, -1.0, -1.0),
            (-1.0, -1.0, 1.0),
        ]
        .iter()
        .enumerate()
        {
            text.push_str(&format!(
                "[[sensor]]\nname = \"u{i}\"\nposition = [{}, {}, {}]\nnoise = 0.035\n",
                x * a,
                y * a,
                z * h
            ));
        }
        ArrangementFile::parse(&text, "board")
            .unwrap()
            .load("board")
            .unwrap()
    }

    #[test]
    fn a_small_flat_board_gets_model_f_and_a_large_cube_keeps_model_g() {
        // The MIMU4444's geometry: 18.9 mm square, 2 mm thick.
        let file = std::path::Path::new("board.toml");
        let (m, note) = recommend(None, &board(0.00945, 0.001), file).unwrap();
        assert_eq!(m, Model::FreeFloat);
        assert!(note.unwrap().contains("diagonal"));
        // A 0.2 m cube with the same parts.
        let (m, note) = recommend(None, &board(0.1, 0.1), file).unwrap();
        assert_eq!(m, Model::General, "{note:?}");
        // Asked for, it is used.
        assert_eq!(
            recommend(Some(Model::General), &board(0.00945, 0.001), file)
                .unwrap()
                .0,
            Model::General
        );
    }
}

#[cfg(test)]
mod explicit {
    use super::*;
    use crate::arrangement_file::ArrangementFile;

    /// Nine channels from three tri-axial parts.
    fn nine(model: &str) -> LoadedArrangement {
        let mut text = format!("{model}\n");
        for (i, p) in [[0.1, 0.0, 0.0], [0.0, 0.1, 0.0], [0.0, 0.0, 0.1]]
            .iter()
            .enumerate()
        {
            text.push_str(&format!(
                "[[sensor]]\nname = \"u{i}\"\nposition = [{}, {}, {}]\nnoise = 0.002\n",
                p[0], p[1], p[2]
            ));
        }
        ArrangementFile::parse(&text, "nine")
            .unwrap()
            .load("nine")
            .unwrap()
    }

    #[test]
    fn a_named_model_general_on_nine_channels_is_an_error_and_no_name_lets_ballisto_choose() {
        let file = std::path::Path::new("nine.toml");
        let e = recommend(None, &nine("model = \"general\""), file).unwrap_err();
        assert!(
            e.starts_with("nine.toml: model = \"general\" needs at least 12"),
            "{e}"
        );
        let (m, note) = recommend(None, &nine(""), file).unwrap();
        assert_eq!(m, Model::FreeFloat);
        assert!(note.is_some());
        let (m, note) = recommend(None, &nine("model = \"free-float\""), file).unwrap();
        assert_eq!((m, note), (Model::FreeFloat, None));
    }
}
