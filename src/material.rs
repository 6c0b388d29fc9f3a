//! Linear elasticity in 2D: the compliance A and the densities of the constitutive term and
//! of the energy for each norm preset (docs/design.md §2, §3).

use crate::read::scene::{Material, Norm};

/// Lamé constants of the 2D model: μ and λ (plane strain λ, ∞ at ν = 0.5; plane stress λ*).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Elastic {
    pub mu: f64,
    pub lambda: f64,
}

impl Elastic {
    /// The constants of a scene's material ([`Material::mu`], [`Material::lambda`]).
    pub fn new(m: &Material) -> Elastic {
        Elastic {
            mu: m.mu(),
            lambda: m.lambda(),
        }
    }

    /// The compliance of a 2×2 tensor τ (row-major `[xx, xy, yx, yy]`), with d = 2:
    ///
    /// A τ = 1/(2μ) · (τ − λ/(2μ + 2λ) · tr(τ) I),  and for λ = ∞: A τ = dev(τ)/(2μ).
    ///
    /// λ/(2μ + 2λ) is evaluated as 1/(2μ/λ + 2), which tends to ½ without cancellation.
    #[inline]
    pub fn compliance(&self, t: [f64; 4]) -> [f64; 4] {
        let c = 1.0 / (2.0 * self.mu / self.lambda + 2.0);
        let s = 0.5 / self.mu;
        let tr = t[0] + t[3];
        [s * (t[0] - c * tr), s * t[1], s * t[2], s * (t[3] - c * tr)]
    }

    /// Cε = 2μ ε + λ tr(ε) I (finite λ only).
    #[inline]
    pub fn stress(&self, e: [f64; 4]) -> [f64; 4] {
        let l = self.lambda * (e[0] + e[3]);
        [
            2.0 * self.mu * e[0] + l,
            2.0 * self.mu * e[1],
            2.0 * self.mu * e[2],
            2.0 * self.mu * e[3] + l,
        ]
    }

    /// Density of the constitutive term for the mismatch e = ε(v) − Aτ (docs/design.md §3):
    ///
    /// - energy: ½(Ce, e) = μ e:e + ½λ (tr e)²
    /// - robust: μ e:e
    /// - seed:   ½ e:e
    #[inline]
    pub fn constitutive_density(&self, norm: Norm, e: [f64; 4]) -> f64 {
        self.bilinear(norm, e, e)
    }

    /// The symmetric bilinear form B of the constitutive density, Q(e) = B(e, e):
    /// energy μ x:y + ½λ tr x tr y, robust μ x:y, seed ½ x:y (docs/design.md §3).
    #[inline]
    pub fn bilinear(&self, norm: Norm, x: [f64; 4], y: [f64; 4]) -> f64 {
        let xy = x[0] * y[0] + x[1] * y[1] + x[2] * y[2] + x[3] * y[3];
        match norm {
            Norm::Energy => self.mu * xy + 0.5 * self.lambda * (x[0] + x[3]) * (y[0] + y[3]),
            Norm::Robust => self.mu * xy,
            Norm::Seed => 0.5 * xy,
        }
    }

    /// Density of the energy that F is compared with: ½(Cε, ε) = μ ε:ε + ½λ (tr ε)² for
    /// `energy`, μ ε:ε for `robust` and `seed` (docs/design.md §8).
    #[inline]
    pub fn energy_density(&self, norm: Norm, eps: [f64; 4]) -> f64 {
        let ee = eps[0] * eps[0] + eps[1] * eps[1] + eps[2] * eps[2] + eps[3] * eps[3];
        match norm {
            Norm::Energy => {
                let tr = eps[0] + eps[3];
                self.mu * ee + 0.5 * self.lambda * tr * tr
            }
            Norm::Robust | Norm::Seed => self.mu * ee,
        }
    }

    /// Weight w_d of the equilibrium term ½ w_d ‖div τ + f‖²: ℓ²/(2μ), or 1 for `seed`.
    pub fn equilibrium_weight(&self, norm: Norm, length_scale: f64) -> f64 {
        match norm {
            Norm::Seed => 1.0,
            Norm::Energy | Norm::Robust => length_scale * length_scale / (2.0 * self.mu),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::read::scene::Model;

    fn material(nu: f64) -> Elastic {
        Elastic::new(&Material {
            youngs_modulus: 20600.0,
            poisson_ratio: nu,
            model: Model::PlaneStrain,
        })
    }

    /// A(Cε) = ε for symmetric ε: the compliance inverts the plane-strain elasticity.
    #[test]
    fn compliance_inverts_elasticity() {
        let m = material(0.28);
        let eps = [1e-3, 2e-4, 2e-4, -5e-4];
        let back = m.compliance(m.stress(eps));
        for k in 0..4 {
            assert!((back[k] - eps[k]).abs() <= 1e-18, "{back:?}");
        }
    }

    /// λ = ∞: A τ = dev τ/(2μ), and a pressure is in the kernel.
    #[test]
    fn incompressible_compliance_is_deviatoric() {
        let m = material(0.5);
        assert!(m.lambda.is_infinite());
        let p = m.compliance([7.0, 0.0, 0.0, 7.0]);
        assert_eq!(p, [0.0; 4]);
        let t = [3.0, 1.0, 1.0, -1.0];
        let a = m.compliance(t);
        // dev t = [2, 1, 1, −2]; 2μ = E/(1+ν) = 20600/1.5.
        let two_mu = 20600.0 / 1.5;
        for (k, d) in [2.0, 1.0, 1.0, -2.0].iter().enumerate() {
            assert!((a[k] - d / two_mu).abs() <= 1e-18);
        }
    }

    /// ν → 0.5: the compliance converges to the incompressible one at rate O(1 − 2ν).
    #[test]
    fn nearly_incompressible_compliance_converges() {
        let t = [3.0, 1.0, 1.0, -1.0];
        let limit = material(0.5).compliance(t);
        let near = material(0.4999999).compliance(t);
        for k in 0..4 {
            assert!((near[k] - limit[k]).abs() <= 1e-6 * limit[0].abs());
        }
    }

    /// The densities by hand: e = diag(1, 1): e:e = 2, tr e = 2.
    #[test]
    fn densities_by_hand() {
        let m = Elastic {
            mu: 3.0,
            lambda: 5.0,
        };
        let e = [1.0, 0.0, 0.0, 1.0];
        assert_eq!(
            m.constitutive_density(Norm::Energy, e),
            3.0 * 2.0 + 0.5 * 5.0 * 4.0
        );
        assert_eq!(m.constitutive_density(Norm::Robust, e), 6.0);
        assert_eq!(m.constitutive_density(Norm::Seed, e), 1.0);
        assert_eq!(m.energy_density(Norm::Seed, e), 6.0);
        assert_eq!(m.equilibrium_weight(Norm::Energy, 2.0), 4.0 / 6.0);
    }
}
