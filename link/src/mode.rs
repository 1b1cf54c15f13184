//! The unit's mode and the estimator model as the link codes them (housekeeping, events,
//! TC[200,1] and TC[200,2]).

use estimator_core::Model;

/// Operating mode.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Mode {
    /// Sampling and housekeeping only; no estimates.
    Standby = 0,
    /// Estimating at sample rate.
    Operate = 1,
}

impl TryFrom<u8> for Mode {
    type Error = u8;

    /// The mode of a code, or the code back if it is none.
    fn try_from(code: u8) -> Result<Self, u8> {
        match code {
            0 => Ok(Mode::Standby),
            1 => Ok(Mode::Operate),
            _ => Err(code),
        }
    }
}

/// The estimator model's code on the link: 0 general (G), 1 free float (F).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ModelCode {
    /// Model G: general field, N ≥ 12.
    General = 0,
    /// Model F: free float (`A = Γ + {Ω}²`, Γ known), N ≥ 9.
    FreeFloat = 1,
}

impl TryFrom<u8> for ModelCode {
    type Error = u8;

    /// The model of a code, or the code back if it is none.
    fn try_from(code: u8) -> Result<Self, u8> {
        match code {
            0 => Ok(ModelCode::General),
            1 => Ok(ModelCode::FreeFloat),
            _ => Err(code),
        }
    }
}

impl From<Model> for ModelCode {
    fn from(model: Model) -> Self {
        match model {
            Model::General => ModelCode::General,
            Model::FreeFloat => ModelCode::FreeFloat,
        }
    }
}

impl From<ModelCode> for Model {
    fn from(code: ModelCode) -> Self {
        match code {
            ModelCode::General => Model::General,
            ModelCode::FreeFloat => Model::FreeFloat,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_round_trip_and_unknown_codes_are_refused() {
        for m in [Mode::Standby, Mode::Operate] {
            assert_eq!(Mode::try_from(m as u8), Ok(m));
        }
        for m in [Model::General, Model::FreeFloat] {
            let code = ModelCode::from(m);
            assert_eq!(Model::from(ModelCode::try_from(code as u8).unwrap()), m);
        }
        assert_eq!(Mode::try_from(2), Err(2));
        assert_eq!(ModelCode::try_from(7), Err(7));
    }
}
