//! Specialisation: a [`KarisHair`]'s component flags turned into const
//! generics once per batch, so that a disabled lobe is compiled out of the
//! loop rather than branched over per element.

use super::KarisHair;
use crate::math::Real;

impl<T: Real> KarisHair<T> {
    /// Runs `visitor` with the kernel monomorphized for this model's
    /// components: one branch per call, none per element.
    #[inline]
    pub fn dispatch<V: LobeVisitor<T>>(&self, visitor: V) -> V::Out {
        let c = self.components;
        macro_rules! k {
            ($r:literal, $tt:literal, $trt:literal, $ms:literal) => {
                visitor.visit::<$r, $tt, $trt, $ms>(self)
            };
        }
        match (c.r, c.tt, c.trt, c.ms) {
            (true, true, true, true) => k!(true, true, true, true),
            (true, true, true, false) => k!(true, true, true, false),
            (true, true, false, true) => k!(true, true, false, true),
            (true, true, false, false) => k!(true, true, false, false),
            (true, false, true, true) => k!(true, false, true, true),
            (true, false, true, false) => k!(true, false, true, false),
            (true, false, false, true) => k!(true, false, false, true),
            (true, false, false, false) => k!(true, false, false, false),
            (false, true, true, true) => k!(false, true, true, true),
            (false, true, true, false) => k!(false, true, true, false),
            (false, true, false, true) => k!(false, true, false, true),
            (false, true, false, false) => k!(false, true, false, false),
            (false, false, true, true) => k!(false, false, true, true),
            (false, false, true, false) => k!(false, false, true, false),
            (false, false, false, true) => k!(false, false, false, true),
            (false, false, false, false) => k!(false, false, false, false),
        }
    }
}

/// Code run with a [`KarisHair`] kernel specialised for one set of
/// components (see [`KarisHair::dispatch`]).
pub trait LobeVisitor<T: Real> {
    type Out;
    fn visit<const R: bool, const TT: bool, const TRT: bool, const MS: bool>(
        self,
        m: &KarisHair<T>,
    ) -> Self::Out;
}
