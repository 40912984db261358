//! ChiangHair importance sampling, as Mitsuba's `hair::sample`: the lobe
//! chosen by its attenuation, θ about the tilted specular cone (d'Eon's
//! M_p inverted), the azimuth by the trimmed logistic about Φ_p.

use super::{finite_or_zero, finite_or_zero3, ChiangHair, Geometry, P_MAX};
use crate::fiber::frame::{azimuth, from_angles, offset, sin_cos_theta, Vec3};
use crate::math::{circ, trimmed_logistic_sample, Real};

impl<T: Real> ChiangHair<T> {
    /// Importance-samples `wo` for unit `wi`. `u1` picks the lobe (and is
    /// reused, rescaled, for the azimuth); `u2` drives θ and the azimuth.
    /// Returns `(wo, f/pdf, pdf)`; `pdf == 0` marks a failed sample (weight 0).
    pub fn sample(&self, wi: &Vec3<T>, u1: T, u2: [T; 2]) -> (Vec3<T>, [T; 3], T) {
        let (sin_theta_i, cos_theta_i) = sin_cos_theta(wi);
        let (gamma_i, h, cos_gamma_i) = offset(wi);
        let phi_i = azimuth(wi);
        let (gamma_t, transmittance) = self.transmission(sin_theta_i, cos_theta_i, h);
        let a_pdf =
            Self::attenuation_pdf(&self.attenuation(cos_theta_i, cos_gamma_i, transmittance));

        // Choose the lobe p by inverting the discrete CDF of A_p; keep the
        // remainder of u1, rescaled to [0, 1], for the azimuthal sample.
        let mut u0 = u1;
        let mut u_phi = if a_pdf[0] > T::ZERO {
            u0 / a_pdf[0]
        } else {
            T::ZERO
        };
        let mut p = 0;
        for i in 0..P_MAX {
            let take = a_pdf[i] < u0;
            u0 -= a_pdf[i];
            if take {
                p = i + 1;
                u_phi = if a_pdf[i + 1] > T::ZERO {
                    u0 / a_pdf[i + 1]
                } else {
                    T::ZERO
                };
            }
        }
        let u_phi = u_phi.max(T::ZERO).min(T::ONE);

        // Longitudinal sample about the tilted specular cone.
        let (sin_ip, cos_ip) = self.reframe_with_scales(sin_theta_i, cos_theta_i, p);
        let v = self.v[p];
        let u_theta = u2[0].max(T::from_f64(1e-5));
        let cos_theta = (T::ONE + v * (u_theta + (T::ONE - u_theta) * (-T::TWO / v).exp()).ln())
            .max(-T::ONE)
            .min(T::ONE);
        let sin_theta = circ(cos_theta);
        let cos_phi = (T::TWO_PI * u2[1]).cos();
        let sin_theta_o = (-cos_theta * sin_ip + sin_theta * cos_phi * cos_ip)
            .max(-T::ONE)
            .min(T::ONE);
        let cos_theta_o = circ(sin_theta_o);

        // Azimuthal sample about the perfect-specular azimuth (uniform for the residual).
        let delta_phi = if p < P_MAX {
            let pf = T::from_f64(p as f64);
            T::TWO * pf * gamma_t - T::TWO * gamma_i
                + pf * T::PI
                + trimmed_logistic_sample(u_phi, self.s)
        } else {
            T::TWO_PI * u_phi
        };
        let wo = from_angles(sin_theta_o, cos_theta_o, phi_i + delta_phi);

        let g = Geometry {
            sin_theta_i,
            cos_theta_i,
            sin_theta_o,
            cos_theta_o,
            delta_phi,
        };
        let d = self.lobe_densities(&g, &self.longitudinal_terms(&g), gamma_i, gamma_t);
        let pdf =
            finite_or_zero(a_pdf[0] * d[0] + a_pdf[1] * d[1] + a_pdf[2] * d[2] + a_pdf[3] * d[3]);
        if pdf <= T::ZERO {
            return (wo, [T::ZERO; 3], T::ZERO);
        }
        let f = self.eval(wi, &wo);
        (wo, finite_or_zero3(f.map(|x| x / pdf)), pdf)
    }
}
