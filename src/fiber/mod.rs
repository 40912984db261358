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
