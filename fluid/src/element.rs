//! The rotated trilinear nonconforming element Q1~ of Rannacher & Turek (1992) with face
//! mean values as degrees of freedom, on an axis-aligned box cell.
//!
//! # Reference element
//! On the reference cube `[-1,1]^3` the local space is
//! `Q1~ = span{1, x, y, z, x^2 - y^2, y^2 - z^2}` (Rannacher & Turek 1992, Numer. Meth.
//! PDE 8:97, eq. (3.3) in 3D; Turek 1999, "Efficient solvers for incompressible flow
//! problems", sec. 3.1.1), and the six degrees of freedom are the mean values over the six
//! faces, ordered `[x-, x+, y-, y+, z-, z+]`. The nodal basis dual to these functionals is
//!
//! `phi_{a+-}(xi) = 1/6 +- xi_a / 2 + (2 xi_a^2 - xi_b^2 - xi_c^2) / 4`,   `{a, b, c} = {x, y, z}`
//!
//! (derivation: `2 xi_a^2 - xi_b^2 - xi_c^2 = 2 (xi_a^2 - xi_b^2) + (xi_b^2 - xi_c^2)`, up to
//! renaming, lies in the space; its face means are `4/3` on the two `a`-faces and `-2/3` on
//! the four others, so `1/6 +- xi_a/2 + r_a/4` has mean 1 on face `a+-` and 0 on the other
//! five). This is checked by quadrature in the tests.
//!
//! # Parametric = nonparametric here
//! The parametric variant maps the reference space with the trilinear cell map, the
//! nonparametric one (Turek 1999, sec. 3.1.1) builds the space in local coordinates along
//! the axes joining opposite face midpoints. On the axis-aligned boxes of this crate the
//! cell map is the diagonal affine `x = x_c + (h/2) xi`, both axes systems coincide, and the
//! two variants are the same space.
//!
//! # Element matrices on a box `hx x hy x hz`
//! With `V = hx hy hz`, `dx = V/8 dxi` and `d/dx_d = (2/h_d) d/dxi_d`, the integrals of the
//! basis over the reference cube (exact; the integrands are polynomials of degree <= 4,
//! integrated exactly by 3-point Gauss rules in the tests) are, with `int xi^2 = 8/3`,
//! `int xi^4 = 8/5`, `int xi^2 eta^2 = 8/9`:
//!
//! * mass `M_ij = int phi_i phi_j dx = V/360 * {52 same face, -8 opposite face, 4 adjacent}`
//!   (row sum `V/6`, so the lumped mass of a face is `V/6` per adjacent cell);
//! * stiffness `K_ij = int grad phi_i . grad phi_j dx = sum_d c_d I^d_ij` with
//!   `c_d = V / (2 h_d^2)` and the reference integrals
//!   `I^a(a+-, a+-) = 14/3`, `I^a(a+, a-) = 2/3`, `I^a(a+-, b+-) = -4/3`,
//!   `I^c(i, j) = 2/3` for faces `i, j` not of family `c`; hence
//!   `K(a, a) = 14/3 c_a + 2/3 (c_b + c_c)`, `K(a+, a-) = 2/3 (c_a + c_b + c_c)`,
//!   `K(a, b) = -4/3 (c_a + c_b) + 2/3 c_c` (rows sum to zero). For a cube of side `h`:
//!   `3h`, `h`, `-h`.
//! * divergence: `int_T d phi_i / dx_d dx = int_dT phi_i n_d dA = |F_i| n_d(F_i)`, so the
//!   discrete divergence of a cell only sees the normal velocity component of its faces.

/// Values of the six basis functions `[x-, x+, y-, y+, z-, z+]` at the reference point
/// `xi` of `[-1,1]^3`: `phi_{a+-} = 1/6 +- xi_a/2 + (2 xi_a^2 - xi_b^2 - xi_c^2)/4`.
pub fn basis(xi: [f64; 3]) -> [f64; 6] {
    let sq = xi.map(|t| t * t);
    let mut out = [0.0; 6];
    for a in 0..3 {
        let r = 2.0 * sq[a] - sq[(a + 1) % 3] - sq[(a + 2) % 3];
        out[2 * a] = 1.0 / 6.0 - 0.5 * xi[a] + 0.25 * r;
        out[2 * a + 1] = 1.0 / 6.0 + 0.5 * xi[a] + 0.25 * r;
    }
    out
}

/// Reference gradients `d phi_i / d xi_d` of the six basis functions at `xi`:
/// `d phi_{a+-}/d xi_a = +-1/2 + xi_a`, `d phi_{a+-}/d xi_b = -xi_b/2` (`b != a`).
pub fn basis_gradient(xi: [f64; 3]) -> [[f64; 3]; 6] {
    let mut out = [[0.0; 3]; 6];
    for a in 0..3 {
        for (s, sign) in [(0, -1.0), (1, 1.0)] {
            let g = &mut out[2 * a + s];
            for (d, gd) in g.iter_mut().enumerate() {
                *gd = if d == a {
                    0.5 * sign + xi[d]
                } else {
                    -0.5 * xi[d]
                };
            }
        }
    }
    out
}

/// Q1~ mass matrix entries of a box of volume `v`: `(same face, opposite face, adjacent
/// face) = V/360 (52, -8, 4)`.
pub fn mass_entries(v: f64) -> (f64, f64, f64) {
    (52.0 * v / 360.0, -8.0 * v / 360.0, 4.0 * v / 360.0)
}

/// Q1~ stiffness (Laplacian) matrix entries of a box of size `h`, see the module docs:
/// `(same[a], opposite[a], adjacent[a][b])` with `c_d = V/(2 h_d^2)`,
/// `K(a,a) = 14/3 c_a + 2/3 (c_b + c_c)`, `K(a+,a-) = 2/3 (c_a + c_b + c_c)`,
/// `K(a,b) = -4/3 (c_a + c_b) + 2/3 c_c`.
pub fn stiffness_entries(h: [f64; 3]) -> ([f64; 3], [f64; 3], [[f64; 3]; 3]) {
    let v = h[0] * h[1] * h[2];
    let c = h.map(|hd| v / (2.0 * hd * hd));
    let sum = c[0] + c[1] + c[2];
    let mut same = [0.0; 3];
    let mut opp = [0.0; 3];
    let mut adj = [[0.0; 3]; 3];
    for a in 0..3 {
        same[a] = 14.0 / 3.0 * c[a] + 2.0 / 3.0 * (sum - c[a]);
        opp[a] = 2.0 / 3.0 * sum;
        for b in 0..3 {
            if b != a {
                let rest = sum - c[a] - c[b];
                adj[a][b] = -4.0 / 3.0 * (c[a] + c[b]) + 2.0 / 3.0 * rest;
            }
        }
    }
    (same, opp, adj)
}

/// Element matrices of the transposed-gradient part of the deformation-tensor viscous
/// term on a box of size `h`: `2 int D(u) : D(v) = int grad u : grad v + int (grad u)^T :
/// grad v`, and with `v = phi_F e_i`, `u_j = sum_G u_j(G) phi_G` the second term is
/// `sum_j sum_G E[i][j][F][G] u_j(G)` with `E[i][j][F][G] = int_T d phi_G/dx_i d phi_F/dx_j`
/// (faces in the order `[x-, x+, y-, y+, z-, z+]`; the integrand has degree 2, so the
/// 3-point Gauss rule per direction is exact). Symmetric: `E[i][j][F][G] = E[j][i][G][F]`.
pub fn transpose_stiffness_entries(h: [f64; 3]) -> [[[[f64; 6]; 6]; 3]; 3] {
    let v = h[0] * h[1] * h[2];
    let mut e = [[[[0.0; 6]; 6]; 3]; 3];
    for &(x, wx) in &GAUSS3 {
        for &(y, wy) in &GAUSS3 {
            for &(z, wz) in &GAUSS3 {
                let w = wx * wy * wz * v / 8.0;
                let g = basis_gradient([x, y, z]);
                // physical gradients d phi / dx_d = (2 / h_d) d phi / d xi_d
                let gp = g.map(|gf| [0, 1, 2].map(|d| 2.0 / h[d] * gf[d]));
                for (i, ei) in e.iter_mut().enumerate() {
                    for (j, eij) in ei.iter_mut().enumerate() {
                        for (f, row) in eij.iter_mut().enumerate() {
                            for (gi, out) in row.iter_mut().enumerate() {
                                *out += w * gp[gi][i] * gp[f][j];
                            }
                        }
                    }
                }
            }
        }
    }
    e
}

/// Gauss-Legendre rule with 3 points on `[-1, 1]`: exact for degree <= 5.
pub const GAUSS3: [(f64, f64); 3] = [
    (-0.774_596_669_241_483_4, 5.0 / 9.0),
    (0.0, 8.0 / 9.0),
    (0.774_596_669_241_483_4, 5.0 / 9.0),
];

#[cfg(test)]
mod tests {
    use super::*;

    fn cube_quadrature(mut f: impl FnMut([f64; 3]) -> f64) -> f64 {
        let mut s = 0.0;
        for (x, wx) in GAUSS3 {
            for (y, wy) in GAUSS3 {
                for (z, wz) in GAUSS3 {
                    s += wx * wy * wz * f([x, y, z]);
                }
            }
        }
        s
    }

    /// The basis is dual to the face mean values: mean of phi_i over face j is delta_ij
    /// (2D Gauss on each face, exact for these quadratics).
    #[test]
    fn basis_is_dual_to_face_means() {
        for a in 0..3 {
            for (s, side) in [(0, -1.0), (1, 1.0)] {
                let j = 2 * a + s;
                for i in 0..6 {
                    let mut mean = 0.0;
                    for (u, wu) in GAUSS3 {
                        for (v, wv) in GAUSS3 {
                            let mut xi = [0.0; 3];
                            xi[a] = side;
                            xi[(a + 1) % 3] = u;
                            xi[(a + 2) % 3] = v;
                            mean += wu * wv * basis(xi)[i] / 4.0;
                        }
                    }
                    let want = if i == j { 1.0 } else { 0.0 };
                    assert!((mean - want).abs() < 1e-14, "face {j} phi {i}: {mean}");
                }
            }
        }
    }

    /// The closed-form mass and stiffness entries equal the quadrature of the basis on an
    /// anisotropic box (to 1e-13 relative), and the space reproduces linear functions:
    /// K applied to the face means of x is zero in the rows (constant gradient).
    #[test]
    fn element_matrices_match_quadrature() {
        let h = [0.3, 0.7, 1.1];
        let v = h[0] * h[1] * h[2];
        let (ms, mo, ma) = mass_entries(v);
        let (ks, ko, ka) = stiffness_entries(h);
        for i in 0..6 {
            for j in 0..6 {
                let m = cube_quadrature(|xi| basis(xi)[i] * basis(xi)[j]) * v / 8.0;
                let k = cube_quadrature(|xi| {
                    let g = basis_gradient(xi);
                    (0..3)
                        .map(|d| g[i][d] * g[j][d] * 4.0 / (h[d] * h[d]))
                        .sum::<f64>()
                }) * v
                    / 8.0;
                let (a, b) = (i / 2, j / 2);
                let (m_want, k_want) = if i == j {
                    (ms, ks[a])
                } else if a == b {
                    (mo, ko[a])
                } else {
                    (ma, ka[a][b])
                };
                assert!((m - m_want).abs() < 1e-13 * v, "M {i}{j}: {m} vs {m_want}");
                assert!((k - k_want).abs() < 1e-13, "K {i}{j}: {k} vs {k_want}");
            }
        }
        // gradient check against finite differences of the basis
        let xi = [0.2, -0.4, 0.7];
        let g = basis_gradient(xi);
        for d in 0..3 {
            let mut p = xi;
            let mut m = xi;
            p[d] += 1e-6;
            m[d] -= 1e-6;
            for (i, gi) in g.iter().enumerate() {
                let fd = (basis(p)[i] - basis(m)[i]) / 2e-6;
                assert!((fd - gi[d]).abs() < 1e-8);
            }
        }
    }

    /// `K_T` of a linear field `u = G x`: `sum_j sum_G E[i][j][F][G] u_j(G) =
    /// sum_j G_ji int_T dphi_F/dx_j = sum_j G_ji |F| n_j(F)` (the face means of a linear
    /// field are its face-centre values; any `G`, divergence-free or not), and the
    /// symmetry `E[i][j][F][G] = E[j][i][G][F]`.
    #[test]
    fn transpose_stiffness_of_linear_fields() {
        let h = [0.3, 0.7, 1.1];
        let e = transpose_stiffness_entries(h);
        let gm = [[0.3, -1.2, 0.5], [2.0, 0.7, -0.4], [-0.9, 1.1, 0.25]];
        // face centres of the box centred at 0 and outward normals
        let centre = |f: usize| {
            let mut x = [0.0; 3];
            x[f / 2] = if f % 2 == 0 { -0.5 } else { 0.5 } * h[f / 2];
            x
        };
        let area = |f: usize| h[0] * h[1] * h[2] / h[f / 2];
        let u = |j: usize, f: usize| (0..3).map(|k| gm[j][k] * centre(f)[k]).sum::<f64>();
        for i in 0..3 {
            for f in 0..6 {
                let got: f64 = (0..3)
                    .map(|j| (0..6).map(|g| e[i][j][f][g] * u(j, g)).sum::<f64>())
                    .sum();
                let sign = if f % 2 == 0 { -1.0 } else { 1.0 };
                let want = gm[f / 2][i] * area(f) * sign;
                assert!((got - want).abs() < 1e-12, "i {i} F {f}: {got} vs {want}");
                for (j, ej) in e.iter().enumerate() {
                    for (g, eg) in ej[i].iter().enumerate() {
                        assert!((e[i][j][f][g] - eg[f]).abs() < 1e-14);
                    }
                }
            }
        }
    }
}
