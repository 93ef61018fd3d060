use bevy_ecs::prelude::Resource;

/// Normal damping law of a material.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum DampingLaw {
    /// Seed slide "Models for DEM": F = c_n delta^(3/2) + d_n delta_dot, with a constant
    /// d_n in N s/m.
    Constant(f64),
    /// Damping F_d = -2 sqrt(5/6) beta sqrt(S_n m*) v_n, S_n = 2 E* sqrt(R* delta),
    /// beta = ln e / sqrt(ln^2 e + pi^2) (Tsuji et al. 1992 form as used by LIGGGHTS and
    /// EDEM); gives the coefficient of restitution e for any impact speed.
    Restitution(f64),
}

/// Elastic and damping properties of one material (particle species or wall).
#[derive(Debug, Clone, PartialEq)]
pub struct Material {
    pub name: String,
    /// Solid density, kg/m^3.
    pub density: f64,
    /// Young's modulus E, Pa.
    pub youngs_modulus: f64,
    /// Poisson's ratio nu.
    pub poisson_ratio: f64,
    pub damping: DampingLaw,
}

/// Contact parameters of one material pair, precomputed for the force loops.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PairParams {
    /// (4/3) E* of the pair, where 1/E* = (1-nu_i^2)/E_i + (1-nu_j^2)/E_j. With the seed's
    /// k_l = (1-nu_l^2)/(pi E_l): c_n = 4/(3 pi (k_i+k_j)) sqrt(R) = (4/3) E* sqrt(R).
    pub hertz_factor: f64,
    /// Constant normal damping d_n (N s/m), zero when the restitution law is used.
    pub damping_constant: f64,
    /// -2 sqrt(5/6) beta for the restitution law (>= 0), zero otherwise.
    pub restitution_factor: f64,
}

/// Materials of the scene and the precomputed pair table (row-major, `n x n`).
/// Walls use the same materials; `wall` pairs are looked up as `pair(wall_mat, species)`.
#[derive(Resource, Debug, Clone, Default)]
pub struct Materials {
    pub list: Vec<Material>,
    pub pairs: Vec<PairParams>,
}

impl Materials {
    #[inline(always)]
    pub fn pair(&self, a: u16, b: u16) -> &PairParams {
        &self.pairs[a as usize * self.list.len() + b as usize]
    }
}

/// Body acceleration per material: g (1 - rho_f / rho), the seed's Newton-Euler
/// translation term (rho - rho_f) V g divided by the particle mass rho V.
#[derive(Resource, Debug, Clone, Default)]
pub struct BodyAcceleration {
    pub per_material: Vec<[f64; 3]>,
}
