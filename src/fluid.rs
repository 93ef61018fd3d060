//! The fluid part of a scene: its grid (`grainflow-fluid`), and the figures
//! `grainflow check` prints about it (degrees of freedom per level, time-step numbers).
use std::fmt::Write as _;
use std::path::Path;

use grainflow_fluid::{
    Boundaries, BoundaryKind, Grid, GridError, NavierStokes, NsConfig, PressureForce, TimeScheme,
    ViscousForm,
};

use grainflow_systems::fluid::{FluidFlow, FluidStats};

use crate::obstacles::{obstacle_faces, obstacle_name, wall_thickness};
use crate::outlets::{outlet_faces, outlet_name, outlet_velocity};

use crate::scene::{
    Fluid, FluidBoundary, FluidPressureForce, FluidScheme, FluidViscous, InflowProfile, SceneError,
};

/// Coarse cells of the fluid box: `cells`, or the box divided by `cell_size`.
pub fn coarse_cells(f: &Fluid) -> [usize; 3] {
    match (f.cells, f.cell_size, f.min, f.max) {
        (Some(cells), _, _, _) => cells,
        (None, Some(h), Some(min), Some(max)) => {
            [0, 1, 2].map(|d| ((max[d] - min[d]) / h).round() as usize)
        }
        _ => unreachable!("validated fluid grid"),
    }
}

/// Boundary kinds of the six sides.
pub fn boundary_kinds(f: &Fluid) -> Boundaries {
    f.boundaries.sides().map(|side| {
        side.map(|(_, b)| match b {
            FluidBoundary::Wall { .. } | FluidBoundary::Inflow { .. } => BoundaryKind::Dirichlet,
            FluidBoundary::Outflow => BoundaryKind::DoNothing,
            FluidBoundary::Periodic => BoundaryKind::Periodic,
        })
    })
}

/// The grid of the scene's fluid at its level; `None` without a fluid grid.
pub fn fluid_grid(f: &Fluid, path: &Path) -> Result<Option<Grid>, SceneError> {
    if !f.has_grid() {
        return Ok(None);
    }
    let (min, max) = (f.min.expect("validated"), f.max.expect("validated"));
    let grid = Grid::new(min, max, coarse_cells(f), f.level, boundary_kinds(f)).map_err(|e| {
        SceneError {
            file: path.to_path_buf(),
            field: match e {
                GridError::EmptyBox { .. } => "fluid.max",
                GridError::NoCells { .. } => "fluid.cells",
                GridError::LevelZero => "fluid.level",
                GridError::HalfPeriodic { .. } => "fluid.boundaries",
            }
            .into(),
            message: e.to_string(),
        }
    })?;
    let (cfl, limit) = (cfl_number(f, &grid), cfl_limit(f.scheme));
    if cfl > limit {
        return Err(SceneError {
            file: path.to_path_buf(),
            field: "fluid.dt".into(),
            message: format!(
                "the CFL number U dt / h = {cfl:.3} (U = {:.3e}, h = {:.3e} at level {}) exceeds \
                 {limit} for the {:?} scheme; expected dt <= {:.3e}",
                boundary_speed(f),
                grid.h().into_iter().fold(f64::INFINITY, f64::min),
                grid.level,
                f.scheme,
                limit * f.dt.unwrap_or_default() / cfl
            ),
        });
    }
    Ok(Some(grid))
}

/// Largest CFL number `U dt / h` accepted for each scheme (U the largest boundary speed,
/// h the smallest cell edge of the run's level). The schemes are implicit, but the
/// convection is linearised about a velocity extrapolated from the previous substeps (one
/// Picard step per substep), and Crank-Nicolson does not damp stiff modes: beyond these
/// numbers the lid-driven cavity (16^2 cells, Re = 100 and 400, up to 100 steps,
/// measured with `grainflow-fluid`) no longer settles and flips from step to step
/// (largest change per step 0.3-1 of the lid speed): Crank-Nicolson settles at
/// U dt/h = 2 and flips at 4 (Re = 100); fractional-step theta settles at 8 and flips at
/// 16 (both Re); backward Euler settles up to 32 on 16^2 and flips at 48 on 24^2
/// (Re = 400). A scene with `dt` beyond its scheme's number exits 2 naming `fluid.dt`;
/// scenes without a moving boundary (U = 0) have no limit.
pub fn cfl_limit(scheme: FluidScheme) -> f64 {
    match scheme {
        FluidScheme::CrankNicolson => 2.0,
        FluidScheme::FractionalStep => 8.0,
        FluidScheme::BackwardEuler => 32.0,
    }
}

/// The CFL number `U dt / h` of the run's level (see [`cfl_limit`]).
pub fn cfl_number(f: &Fluid, grid: &Grid) -> f64 {
    let h = grid.h().into_iter().fold(f64::INFINITY, f64::min);
    boundary_speed(f) * f.dt.unwrap_or_default() / h
}

/// Largest speed prescribed on the boundary (walls, lids, inflow peaks, outlets).
pub fn boundary_speed(f: &Fluid) -> f64 {
    f.boundaries
        .sides()
        .iter()
        .flatten()
        .map(|(_, b)| match b {
            FluidBoundary::Wall { velocity } | FluidBoundary::Inflow { velocity, .. } => {
                velocity.iter().map(|v| v * v).sum::<f64>().sqrt()
            }
            _ => 0.0,
        })
        .chain(f.outlets.iter().map(|o| o.velocity.abs()))
        .fold(0.0, f64::max)
}

/// The `grainflow check` block of a fluid grid: box, viscosity, boundaries, the degrees of
/// freedom of levels 1 to max(5, level) (3 x faces + cells; a periodic pair of sides
/// shares its faces), and the time-step numbers
/// of the run's level: the CFL number U dt / h with the largest boundary speed U and its
/// limit for the scheme ([`cfl_limit`]), and the viscous number nu dt / h^2 (the viscous
/// term is implicit, so it is reported, not limited).
pub fn check_report(f: &Fluid, grid: &Grid) -> String {
    let mut out = String::new();
    let coarse = grid.coarse;
    let _ = writeln!(
        out,
        "fluid      box {:?} .. {:?}, nu = {:e}, rho_f = {}, coarse cells {coarse:?}, level {}",
        grid.lower,
        grid.upper,
        f.viscosity.unwrap_or_default(),
        f.density,
        grid.level
    );
    let _ = writeln!(
        out,
        "  scheme {:?}, viscous term {:?}, pressure force {:?}, upwind scale {}, dt_F = {:e} s",
        f.scheme,
        f.viscous,
        f.pressure_force.unwrap_or(FluidPressureForce::Normal),
        f.upwind,
        f.dt.unwrap_or_default()
    );
    if let Some(s) = f.solve_upwind {
        let _ = writeln!(
            out,
            "  deferred upwind correction: the momentum multigrid solves with upwind scale {s}"
        );
    }
    for side in f.boundaries.sides().iter().flatten() {
        let what = match side.1 {
            FluidBoundary::Wall { velocity } if velocity.iter().all(|v| *v == 0.0) => {
                "no-slip wall".to_string()
            }
            FluidBoundary::Wall { velocity } => format!("moving wall, velocity {velocity:?}"),
            FluidBoundary::Inflow { velocity, profile } => format!(
                "inflow, {} {velocity:?}",
                match profile {
                    InflowProfile::Uniform => "uniform",
                    InflowProfile::Parabolic => "parabolic, peak",
                }
            ),
            FluidBoundary::Outflow => "do-nothing outflow".to_string(),
            FluidBoundary::Periodic => "periodic".to_string(),
        };
        let _ = writeln!(out, "  {:4} {what}", side.0);
    }
    let _ = writeln!(out, "  level  cells                faces       DOFs");
    for level in 1..=grid.level.max(5) {
        let scale = 1usize << (level - 1);
        let n = coarse.map(|c| c * scale);
        let cells = n[0] * n[1] * n[2];
        let dofs = Grid {
            level,
            ..grid.clone()
        }
        .dofs();
        let faces = (dofs - cells) / 3;
        let _ = writeln!(
            out,
            "  {level:5}  {:<20} {faces:>10} {dofs:>10}{}",
            format!("{}x{}x{} = {cells}", n[0], n[1], n[2]),
            if level == grid.level {
                "  <- this run"
            } else {
                ""
            }
        );
    }
    let h = grid.h().into_iter().fold(f64::INFINITY, f64::min);
    for (k, o) in f.obstacles.iter().enumerate() {
        let held = obstacle_faces(std::slice::from_ref(o), grid).len();
        let cells = wall_thickness(o) / h;
        let _ = writeln!(
            out,
            "  obstacle {}: {held} faces held at rest, wall {cells:.2} cells thick",
            obstacle_name(o, k)
        );
        if held == 0 {
            let _ = writeln!(
                out,
                "warning: obstacle {} holds no face: it lies outside the box or between face centres",
                obstacle_name(o, k)
            );
        } else if cells < 1.0 {
            let _ = writeln!(
                out,
                "warning: obstacle {}'s wall is {cells:.2} cells thick: below one cell the flow can pass through it (raise fluid.level or thicken it)",
                obstacle_name(o, k)
            );
        }
    }
    for (k, o) in f.outlets.iter().enumerate() {
        let held = outlet_faces(o, grid).len();
        let area = held as f64 * grid.face_area(o.side.direction_and_side().0);
        let disc = std::f64::consts::PI * o.radius * o.radius;
        let _ = writeln!(
            out,
            "  outlet {} on {}: {held} faces of area {area:.4e} for the disc's {disc:.4e}, flux {:.4e} (normal speed {:.4e} on the faces)",
            outlet_name(o, k),
            o.side.name(),
            disc * o.velocity,
            outlet_velocity(o, grid, held)[o.side.direction_and_side().0].abs()
        );
        if held == 0 {
            let _ = writeln!(
                out,
                "warning: outlet {} holds no face: its disc misses the side's face centres",
                outlet_name(o, k)
            );
        }
    }
    let dt = f.dt.unwrap_or_default();
    let u = boundary_speed(f);
    let nu = f.viscosity.unwrap_or_default();
    let limit = cfl_limit(f.scheme);
    let _ = writeln!(
        out,
        "  time step: CFL U dt/h = {:.3} (U = {u:.3e}, h = {h:.3e}; limit {limit} for {:?}: dt <= {}), viscous nu dt/h^2 = {:.3} (implicit: reported, not limited; dt at nu dt/h^2 = 1/2: {:.3e} s)",
        cfl_number(f, grid),
        f.scheme,
        if u > 0.0 {
            format!("{:.3e} s", limit * h / u)
        } else {
            "any".to_string()
        },
        nu * dt / (h * h),
        0.5 * h * h / nu
    );
    let cfl = cfl_number(f, grid);
    if cfl > MULTIGRID_CFL {
        let _ = writeln!(
            out,
            "warning: U dt/h = {cfl:.3} is above {MULTIGRID_CFL}, where the momentum multigrid slows down and flows with a fast start can run away; dt <= {:.3e} s keeps it below (and is usually faster per simulated second)",
            MULTIGRID_CFL * h / u
        );
    }
    out
}

/// The CFL number `U dt / h` above which `grainflow check` warns: the momentum multigrid
/// (one Picard step per substep) converges more slowly as convection dominates the
/// operator, and a flow that starts at full speed can run away. Measured on the drag
/// case's 2 x 2 x 6 channel without the sphere at Re = 150 (U = 6, level 3, backward
/// Euler, shared pressure force, first 0.2-0.4 s from rest): mean reduction per cycle
/// 0.21 / 0.34 / 0.53 at U dt/h = 2.9 / 4.3 / 5.8, seconds per fluid step 1.2 / 2.0 /
/// 3.4 (so the shortest step costs the least per simulated second), and a runaway in the
/// second fluid step at 7.2 (the normal pressure force: 0.57 and 4.2 s per step there).
/// Steady flows go further (the Re = 50 drag case at level 4 runs at 4.8), so this warns
/// and the hard bound stays [`cfl_limit`].
pub const MULTIGRID_CFL: f64 = 4.0;

/// The flow solver of the scene's fluid grid, at rest, with the boundary velocities set:
/// walls and lids their velocity, inflows their uniform velocity or the parabolic profile
/// U prod_t 4 (x_t - a_t)(b_t - x_t)/(b_t - a_t)^2 over the side's two tangential
/// directions t (peak U at the side's centre, zero on its edges).
pub fn fluid_flow(f: &Fluid, grid: &Grid, gravity: [f64; 3]) -> FluidFlow {
    let dt = f.dt.expect("validated");
    let mut cfg = NsConfig::new(f.viscosity.expect("validated"), dt);
    cfg.body_force = f.body_force;
    cfg.scheme = match f.scheme {
        FluidScheme::FractionalStep => TimeScheme::FractionalStepTheta,
        FluidScheme::CrankNicolson => TimeScheme::CrankNicolson,
        FluidScheme::BackwardEuler => TimeScheme::BackwardEuler,
    };
    cfg.upwind = f.upwind;
    cfg.solve_upwind = f.solve_upwind;
    cfg.momentum_rtol = f.momentum_rtol.unwrap_or(cfg.momentum_rtol);
    cfg.pressure_rtol = f.pressure_rtol.unwrap_or(cfg.pressure_rtol);
    cfg.viscous = match f.viscous {
        FluidViscous::Laplacian => ViscousForm::Laplacian,
        FluidViscous::Deformation => ViscousForm::Deformation,
    };
    // scenes from `scene::parse` have it chosen (see `Fluid::pressure_force`)
    cfg.pressure_force = match f.pressure_force {
        Some(FluidPressureForce::Shared) => PressureForce::Shared,
        Some(FluidPressureForce::Normal) | None => PressureForce::Normal,
    };
    let mut solver = NavierStokes::new(grid, cfg, grid.dirichlet_mask());
    let (lo, hi) = (grid.lower, grid.upper);
    for (d, sides) in f.boundaries.sides().iter().enumerate() {
        for (side, (_, b)) in sides.iter().enumerate() {
            match b {
                FluidBoundary::Wall { velocity } => {
                    solver.set_side_velocity(d, side, |_| *velocity)
                }
                FluidBoundary::Inflow { velocity, profile } => {
                    let (velocity, profile) = (*velocity, *profile);
                    solver.set_side_velocity(d, side, move |x| {
                        let shape = match profile {
                            InflowProfile::Uniform => 1.0,
                            InflowProfile::Parabolic => (0..3)
                                .filter(|&t| t != d)
                                .map(|t| {
                                    4.0 * (x[t] - lo[t]) * (hi[t] - x[t]) / (hi[t] - lo[t]).powi(2)
                                })
                                .product(),
                        };
                        velocity.map(|v| v * shape)
                    })
                }
                FluidBoundary::Outflow | FluidBoundary::Periodic => {}
            }
        }
    }
    // after the sides: an outlet is a part of its side, and an obstacle reaching a side
    // (the wall of a pipe at its mouth) is at rest there too
    for o in &f.outlets {
        let faces = outlet_faces(o, grid);
        solver.hold_faces(&faces, outlet_velocity(o, grid, faces.len()));
    }
    solver.hold_faces(&obstacle_faces(&f.obstacles, grid), [0.0; 3]);
    let norm = |v: [f64; 3]| v.iter().map(|c| c * c).sum::<f64>().sqrt();
    let diagonal = norm([0, 1, 2].map(|d| hi[d] - lo[d]));
    let velocity_scale = boundary_speed(f)
        .max((norm(f.body_force) * diagonal).sqrt())
        .max((norm(gravity) * diagonal).sqrt())
        .max(f.viscosity.expect("validated") / diagonal);
    FluidFlow {
        solver,
        dt,
        next_time: 0.0,
        stats: FluidStats::default(),
        velocity_scale,
    }
}
