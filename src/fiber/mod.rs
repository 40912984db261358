//! Hair fiber scattering models, one per file, all generic over
//! [`Real`](crate::math::Real) (`f32` / `f64`) and all in the frame of
//! [`frame`].

pub mod chiang;
pub mod deon;
pub mod dual;
pub mod frame;
pub mod karis;
pub mod lobes;

pub use chiang::{ChiangHair, ChiangParams, I0Mode};

/// A number as an error message shows it: as Rust prints it between 1e-4
/// and 1e7 in magnitude (and 0), in exponent form outside (`1e39`, not 40
/// digits; `f64::MAX` is not printed as 309 digits).
pub fn number_text(x: f64) -> String {
    if x == 0.0 || !x.is_finite() || (1e-4..1e7).contains(&x.abs()) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// A model parameter outside its allowed range.
#[derive(Debug, Clone, PartialEq)]
pub struct ParamError {
    /// The parameter's public name.
    pub param: &'static str,
    /// What is wrong and the allowed range.
    pub message: String,
}

impl std::fmt::Display for ParamError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}: {}", self.param, self.message)
    }
}

impl std::error::Error for ParamError {}

pub(crate) fn param_error(param: &'static str, message: impl Into<String>) -> ParamError {
    ParamError {
        param,
        message: message.into(),
    }
}

#[cfg(test)]
mod number_text_tests {
    use super::number_text;

    #[test]
    fn t01_large_and_small_numbers_in_exponent_form() {
        assert_eq!(number_text(1e39), "1e39");
        assert_eq!(number_text(f64::MAX), "1.7976931348623157e308");
        assert_eq!(number_text(2.5e-7), "2.5e-7");
        assert_eq!(number_text(0.25), "0.25");
        assert_eq!(number_text(-3.0), "-3");
        assert_eq!(number_text(0.0), "0");
        assert_eq!(number_text(f64::NAN), "NaN");
    }
}
