//! Mass properties of clumps (rigid unions of spheres, `contact/shapes/clump.rs`) against
//! closed forms.
//!
//! The union of equal spheres whose centres lie on a line, spaced s < 2r, is cut by the
//! mid-planes between neighbouring centres into slabs, each holding the cross-sections of
//! its own sphere (the nearest centre gives the widest disc): a disc of radius^2
//! rho^2 = r^2 - (x - c)^2. Volume and inertia are then integrals over x of polynomials,
//! V = sum int pi rho^2 dx, I_xx = sum int pi rho^4 / 2 dx and
//! I_yy = sum int (pi rho^4 / 4 + pi rho^2 x^2) dx (thin discs; x from the centre of
//! mass), computed exactly by Gauss-Legendre quadrature (degree 4 in x, 3 points per
//! slab). Members that do not overlap give the sphere sums with the parallel-axis terms.
//! An overlapping non-collinear clump is checked against a brute-force lattice
//! integration of the union (independent of the code's overlap correction).
use glam::DVec3;
use grainflow_systems::contact::shapes::clump::Clump;
use grainflow_systems::contact::shapes::{principal_axes, rigid_type, ParticleShape};
use std::f64::consts::PI;

/// Volume, I_xx and I_yy (about the centre) of equal spheres of radius `r` centred at
/// `centres` on the x axis (ascending, spaced below 2r), for unit density.
fn collinear_union(r: f64, centres: &[f64]) -> (f64, f64, f64) {
    // Gauss-Legendre, 3 points: exact for polynomials up to degree 5.
    let nodes = [-(0.6f64).sqrt(), 0.0, (0.6f64).sqrt()];
    let weights = [5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0];
    let mean = centres.iter().sum::<f64>() / centres.len() as f64;
    let (mut v, mut ixx, mut iyy) = (0.0, 0.0, 0.0);
    for (k, &c) in centres.iter().enumerate() {
        let lo = if k == 0 {
            c - r
        } else {
            0.5 * (centres[k - 1] + c)
        };
        let hi = if k + 1 == centres.len() {
            c + r
        } else {
            0.5 * (c + centres[k + 1])
        };
        let (mid, half) = (0.5 * (lo + hi), 0.5 * (hi - lo));
        for (t, w) in nodes.iter().zip(weights) {
            let x = mid + half * t;
            let rho2 = r * r - (x - c) * (x - c);
            let dx = w * half;
            v += PI * rho2 * dx;
            ixx += 0.5 * PI * rho2 * rho2 * dx;
            iyy += (0.25 * PI * rho2 * rho2 + PI * rho2 * (x - mean) * (x - mean)) * dx;
        }
    }
    (v, ixx, iyy)
}

fn clump(spheres: &[([f64; 3], f64)]) -> Box<dyn ParticleShape> {
    Clump::from_spheres(spheres).expect("a valid clump")
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

/// Two equal spheres overlapping by half a radius: volume and both inertias within 1e-4
/// of the closed form (the lattice of the overlap correction has 96 cells per radius; its
/// error lies in the lens only).
#[test]
fn two_sphere_clump_matches_the_closed_form() {
    let r = 1.0e-3;
    let s = 1.5 * r;
    let shape = clump(&[([-0.5 * s, 0.0, 0.0], r), ([0.5 * s, 0.0, 0.0], r)]);
    let props = shape.mass_properties();
    let (v, ixx, iyy) = collinear_union(r, &[-0.5 * s, 0.5 * s]);
    // The sum of the two spheres is 2 (4/3) pi r^3 = 8.38e-9 m^3; the union is smaller.
    assert!(v < 8.0 / 3.0 * PI * r.powi(3));
    assert!(
        rel(props.volume, v) < 1e-4,
        "volume {} vs {v}",
        props.volume
    );
    assert!(props.centre.length() < 1e-6 * r, "centre {}", props.centre);
    let (moments, _) = principal_axes(props.inertia);
    assert!(rel(moments.x, ixx) < 1e-4, "I_xx {} vs {ixx}", moments.x);
    assert!(rel(moments.y, iyy) < 1e-4, "I_yy {} vs {iyy}", moments.y);
    assert!(rel(moments.z, iyy) < 1e-4, "I_zz {} vs {iyy}", moments.z);
}

/// Four equal spheres in a line, spaced 1.2 r (each overlapping its neighbours by 0.8 r),
/// off-axis and turned: the principal moments within 1e-4 of the closed form, the axis of
/// the smallest moment along the line, the centre at the line's middle.
#[test]
fn four_sphere_chain_matches_the_closed_form() {
    let r = 0.5;
    let s = 1.2 * r;
    let xs = [0.0, s, 2.0 * s, 3.0 * s];
    let dir = DVec3::new(1.0, 2.0, 2.0) / 3.0;
    let origin = DVec3::new(0.3, -0.2, 0.7);
    let spheres: Vec<([f64; 3], f64)> = xs
        .iter()
        .map(|&x| ((origin + dir * x).to_array(), r))
        .collect();
    let props = clump(&spheres).mass_properties();
    let (v, ixx, iyy) = collinear_union(r, &xs);
    assert!(
        rel(props.volume, v) < 1e-4,
        "volume {} vs {v}",
        props.volume
    );
    let centre = origin + dir * (1.5 * s);
    assert!((props.centre - centre).length() < 1e-5 * r);
    let (moments, axes) = principal_axes(props.inertia);
    assert!(rel(moments.x, ixx) < 1e-4, "I_xx {} vs {ixx}", moments.x);
    assert!(rel(moments.y, iyy) < 1e-4 && rel(moments.z, iyy) < 1e-4);
    assert!(
        axes.x_axis.dot(dir).abs() > 1.0 - 1e-9,
        "axis {}",
        axes.x_axis
    );
}

/// Four spheres at the corners of a regular tetrahedron of edge 2 r (touching, no
/// overlap volume): exactly
/// the sphere sums with the parallel-axis terms, I = 4 (2/5) m r^2 1 + m sum (|d|^2 1 -
/// d d^T), which the tetrahedral symmetry (sum d d^T = (4/3) |d|^2 1) makes isotropic:
/// I = 4 m (2/5 r^2 + (2/3) |d|^2), |d| the corners' distance from the centre.
#[test]
fn four_sphere_tetrahedron_touching_is_exact() {
    let r = 1.0;
    let e = 2.0 * r;
    let corners = [
        DVec3::new(1.0, 1.0, 1.0),
        DVec3::new(1.0, -1.0, -1.0),
        DVec3::new(-1.0, 1.0, -1.0),
        DVec3::new(-1.0, -1.0, 1.0),
    ]
    .map(|c| c * (e / (2.0 * 2f64.sqrt())));
    let spheres = corners.map(|c| (c.to_array(), r));
    let props = clump(&spheres).mass_properties();
    let m = 4.0 / 3.0 * PI * r.powi(3);
    assert!(rel(props.volume, 4.0 * m) < 1e-12);
    let d2 = corners[0].length_squared();
    let expected = 4.0 * m * (0.4 * r * r + 2.0 / 3.0 * d2);
    let (moments, _) = principal_axes(props.inertia);
    for k in 0..3 {
        assert!(
            rel(moments[k], expected) < 1e-12,
            "{} vs {expected}",
            moments[k]
        );
    }
}

/// Four unequal, overlapping, non-coplanar spheres against a brute-force midpoint
/// lattice over the whole union (240^3 cells; its own error is about 1e-4 here): volume,
/// centre and inertia tensor within 1e-3.
#[test]
fn overlapping_four_sphere_clump_matches_a_lattice_integration() {
    let spheres = [
        ([0.0, 0.0, 0.0], 1.0),
        ([1.2, 0.0, 0.0], 0.8),
        ([0.3, 1.1, 0.0], 0.7),
        ([0.4, 0.3, 0.9], 0.6),
    ];
    let props = clump(&spheres).mass_properties();
    let lo = DVec3::splat(-1.0);
    let hi = DVec3::new(2.0, 1.8, 1.5);
    let n = 240;
    let h = (hi - lo) / n as f64;
    let dv = h.x * h.y * h.z;
    let (mut v, mut first, mut second) = (0.0, DVec3::ZERO, [[0.0; 3]; 3]);
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                let p = lo + h * DVec3::new(i as f64 + 0.5, j as f64 + 0.5, k as f64 + 0.5);
                let inside = spheres
                    .iter()
                    .any(|(c, r)| (p - DVec3::from_array(*c)).length_squared() < r * r);
                if inside {
                    v += dv;
                    first += p * dv;
                    for a in 0..3 {
                        for b in 0..3 {
                            second[a][b] += p[a] * p[b] * dv;
                        }
                    }
                }
            }
        }
    }
    let c = first / v;
    assert!(
        rel(props.volume, v) < 1e-3,
        "volume {} vs {v}",
        props.volume
    );
    assert!(
        (props.centre - c).length() < 1e-3,
        "centre {} vs {c}",
        props.centre
    );
    let s = |a: usize, b: usize| second[a][b] - v * c[a] * c[b];
    let trace = s(0, 0) + s(1, 1) + s(2, 2);
    let scale = trace;
    for a in 0..3 {
        for b in 0..3 {
            let expected = if a == b { trace - s(a, a) } else { -s(a, b) };
            let got = props.inertia.col(b)[a];
            assert!(
                (got - expected).abs() < 1e-3 * scale,
                "I[{a}][{b}] {got} vs {expected}"
            );
        }
    }
}

/// The rigid type puts the members in the principal frame: its inertia tensor there is
/// diagonal with the principal moments times the density, and the mass is density times
/// volume (up to the overlap lattice's error, which differs between the two frames: 1e-5
/// of the size for the centre, 1e-4 for the moments).
#[test]
fn rigid_type_members_lie_in_the_principal_frame() {
    let spheres = [
        ([0.0, 0.0, 0.0], 1.0),
        ([1.2, 0.3, 0.0], 0.8),
        ([0.3, 1.1, 0.4], 0.7),
    ];
    let shape = clump(&spheres);
    let density = 2500.0;
    let ty = rigid_type(&*shape, "t", 0, density);
    let props = shape.mass_properties();
    assert!(rel(ty.mass, density * props.volume) < 1e-14);
    let moved: Vec<([f64; 3], f64)> = ty
        .members
        .iter()
        .map(|m| (m.offset.to_array(), m.radius))
        .collect();
    let there = clump(&moved).mass_properties();
    assert!(there.centre.length() < 1e-5, "centre {}", there.centre);
    for a in 0..3 {
        for b in 0..3 {
            let value = there.inertia.col(b)[a] * density;
            if a == b {
                assert!(
                    rel(value, ty.inertia[a]) < 1e-4,
                    "{value} vs {}",
                    ty.inertia[a]
                );
            } else {
                assert!(value.abs() < 1e-4 * ty.inertia.max_element());
            }
        }
    }
    assert!(ty.inertia.x <= ty.inertia.y && ty.inertia.y <= ty.inertia.z);
}

/// A clump whose members do not touch is refused, naming the member.
#[test]
fn disconnected_members_are_refused() {
    let Err(message) = Clump::from_spheres(&[([0.0; 3], 1.0), ([3.0, 0.0, 0.0], 1.0)]) else {
        panic!("a disconnected clump was accepted");
    };
    assert!(message.contains("member 1"), "{message}");
}

/// `grainflow check` counts the clumps of a block and an inflow apart from the member
/// spheres, and prints the type's mass: the closed-form union volume times the density
/// (to its five printed digits).
#[test]
fn check_counts_the_clumps_and_prints_their_mass() {
    let (r, rho) = (1.0e-3, 2500.0);
    let dir = std::env::temp_dir().join(format!("grainflow-clump-check-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let scene = dir.join("scene.toml");
    std::fs::write(
        &scene,
        format!(
            "[simulation]\ndt = 1.0e-6\nend_time = 0.01\n\
             [[materials]]\nname = \"m\"\ndensity = {rho}\nyoungs_modulus = 1.0e7\npoisson_ratio = 0.3\n\
             [[clump_types]]\nname = \"pair\"\nmaterial = \"m\"\n\
             spheres = [{{ offset = [-0.75e-3, 0.0, 0.0], radius = {r:e} }}, {{ offset = [0.75e-3, 0.0, 0.0], radius = {r:e} }}]\n\
             [[blocks]]\nclump = \"pair\"\nmin = [0.0, 0.0, 0.0]\nmax = [0.02, 0.02, 0.02]\ncount = 7\n\
             [[inflows]]\nclump = \"pair\"\nrate = 100.0\ntotal = 5\n\
             region = {{ type = \"box\", min = [0.0, 0.0, 0.04], max = [0.02, 0.02, 0.06] }}\n"
        ),
    )
    .unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_grainflow"))
        .args(["check", scene.to_str().unwrap()])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{text}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(text.contains("particles  14 placed"), "{text}");
    let line = text.lines().find(|l| l.starts_with("clumps")).expect(&text);
    assert!(line.contains("7 placed (14 of the particles"), "{line}");
    assert!(line.contains("5 by inflow"), "{line}");
    let mass: f64 = line
        .split("mass ")
        .nth(1)
        .and_then(|s| s.split(' ').next())
        .and_then(|s| s.parse().ok())
        .expect(line);
    let (v, _, _) = collinear_union(r, &[-0.75e-3, 0.75e-3]);
    assert!(rel(mass, rho * v) < 1e-4, "mass {mass} vs {}", rho * v);
    std::fs::remove_dir_all(&dir).ok();
}
