//! From a scene to an ECS world: materials, walls, particles, and the resources the
//! registered systems need. Systems a scene does not use get no resources.
use std::path::Path;

use bevy_ecs::prelude::World;
use grainflow_components::*;
use grainflow_systems::contact::walls::{wall_contains, wall_distance};
use grainflow_systems::coupling::markers::outside_the_fluid;
use grainflow_systems::inflow::next_f64;

use crate::scene::{
    Axis, BoundaryRuleName, ForceMethodName, InsideFluidName, ParticleUpdateName, RegionSpec,
    Scene, SceneError, SurfaceSpec, WallSpec,
};

/// The pair table: E* from both materials, damping laws averaged when both materials use
/// the same law.
pub fn pair_params(a: &Material, b: &Material) -> Result<PairParams, String> {
    let e_star = 1.0
        / ((1.0 - a.poisson_ratio.powi(2)) / a.youngs_modulus
            + (1.0 - b.poisson_ratio.powi(2)) / b.youngs_modulus);
    let (damping_constant, restitution_factor) = match (a.damping, b.damping) {
        (DampingLaw::Constant(x), DampingLaw::Constant(y)) => (0.5 * (x + y), 0.0),
        (DampingLaw::Restitution(x), DampingLaw::Restitution(y)) => (0.0, restitution_factor(0.5 * (x + y))),
        _ => {
            return Err(format!(
                "materials `{}` and `{}` use different damping laws (normal_damping and restitution): give both the same kind",
                a.name, b.name
            ))
        }
    };
    Ok(PairParams {
        hertz_factor: 4.0 / 3.0 * e_star,
        damping_constant,
        restitution_factor,
    })
}

/// -2 sqrt(5/6) beta with beta = ln e / sqrt(ln^2 e + pi^2) (beta = -1 at e = 0).
pub fn restitution_factor(e: f64) -> f64 {
    let beta = if e <= 0.0 {
        -1.0
    } else {
        let l = e.ln();
        l / (l * l + std::f64::consts::PI.powi(2)).sqrt()
    };
    -2.0 * (5.0f64 / 6.0).sqrt() * beta
}

/// The contact laws one material (or interaction) gives, defaults filled in: friction
/// with mu_d = mu_s, Mindlin stiffness and no damping unless given; rolling with the
/// default stiffness and no damping unless given.
fn surface_law(v: &SurfaceSpec, eight_g_star: f64) -> ContactLaw {
    ContactLaw {
        friction: v.friction.map(|mu_s| FrictionLaw {
            static_coefficient: mu_s,
            dynamic_coefficient: v.dynamic_friction.unwrap_or(mu_s),
            stiffness: v.tangential_stiffness.map_or(
                TangentialStiffness::Mindlin(eight_g_star),
                TangentialStiffness::Constant,
            ),
            damping: v.tangential_damping.unwrap_or(0.0),
        }),
        rolling: v.rolling_friction.map(|mu_r| RollingLaw {
            coefficient: mu_r,
            stiffness: v.rolling_stiffness,
            damping: v.rolling_damping.unwrap_or(0.0),
        }),
        adhesion: v.work_of_adhesion.map(|work| AdhesionLaw { work }),
    }
}

/// 8 G* of a material pair (Mindlin 1949): 1/G* = (2 - nu_a)/G_a + (2 - nu_b)/G_b,
/// G = E / (2 (1 + nu)).
pub fn eight_g_star(a: &Material, b: &Material) -> f64 {
    let g = |m: &Material| m.youngs_modulus / (2.0 * (1.0 + m.poisson_ratio));
    8.0 / ((2.0 - a.poisson_ratio) / g(a) + (2.0 - b.poisson_ratio) / g(b))
}

/// Mix two materials' laws into the pair's: where both give a model, its coefficients,
/// damping and constant stiffnesses are the means (Mindlin when either uses it), the work
/// of adhesion the geometric mean sqrt(W_a W_b); where one gives it, that one's.
fn mix_laws(a: ContactLaw, b: ContactLaw) -> ContactLaw {
    fn either<T>(a: Option<T>, b: Option<T>, both: impl Fn(T, T) -> T) -> Option<T> {
        match (a, b) {
            (Some(x), Some(y)) => Some(both(x, y)),
            (x, y) => x.or(y),
        }
    }
    let mean = |x: f64, y: f64| 0.5 * (x + y);
    ContactLaw {
        friction: either(a.friction, b.friction, |x, y| FrictionLaw {
            static_coefficient: mean(x.static_coefficient, y.static_coefficient),
            dynamic_coefficient: mean(x.dynamic_coefficient, y.dynamic_coefficient),
            stiffness: match (x.stiffness, y.stiffness) {
                (TangentialStiffness::Constant(p), TangentialStiffness::Constant(q)) => {
                    TangentialStiffness::Constant(mean(p, q))
                }
                (TangentialStiffness::Mindlin(g), _) | (_, TangentialStiffness::Mindlin(g)) => {
                    TangentialStiffness::Mindlin(g)
                }
            },
            damping: mean(x.damping, y.damping),
        }),
        rolling: either(a.rolling, b.rolling, |x, y| RollingLaw {
            coefficient: mean(x.coefficient, y.coefficient),
            stiffness: either(x.stiffness, y.stiffness, mean),
            damping: mean(x.damping, y.damping),
        }),
        adhesion: either(a.adhesion, b.adhesion, |x, y| AdhesionLaw {
            work: (x.work * y.work).sqrt(),
        }),
    }
}

/// The pair table of contact laws: mixed from the materials, then each `[[interactions]]`
/// entry replaces the models it gives (all of a model's fields come from the entry).
/// `None` when no pair uses friction, rolling resistance or adhesion.
pub fn contact_laws(scene: &Scene, materials: &[Material]) -> Option<ContactLaws> {
    let n = materials.len();
    let mut pairs = Vec::with_capacity(n * n);
    for (a, ma) in materials.iter().enumerate() {
        for (b, mb) in materials.iter().enumerate() {
            let g8 = eight_g_star(ma, mb);
            let mut law = mix_laws(
                surface_law(&scene.materials[a].surface(), g8),
                surface_law(&scene.materials[b].surface(), g8),
            );
            for i in &scene.interactions {
                let names = [&ma.name, &mb.name];
                if names == [&i.materials[0], &i.materials[1]]
                    || names == [&i.materials[1], &i.materials[0]]
                {
                    let given = surface_law(&i.surface(), g8);
                    law.friction = given.friction.or(law.friction);
                    law.rolling = given.rolling.or(law.rolling);
                    law.adhesion = given.adhesion.or(law.adhesion);
                }
            }
            pairs.push(law);
        }
    }
    if pairs.iter().all(|l| *l == ContactLaw::default()) {
        return None;
    }
    Some(ContactLaws {
        materials: n,
        layout: HistoryLayout::for_laws(&pairs),
        pairs,
    })
}

/// Largest JKR critical separation delta_s over the adhesive pairs, with R* at most
/// `r_max` (delta_s grows as R*^(1/3)): the Verlet skin must exceed it, so that a
/// stretched adhesive contact stays listed.
pub fn largest_critical_separation(laws: &ContactLaws, pairs: &[PairParams], r_max: f64) -> f64 {
    laws.pairs
        .iter()
        .zip(pairs)
        .filter_map(|(law, p)| {
            law.adhesion.map(|a| {
                grainflow_systems::contact::laws::jkr::Jkr {
                    e_star: 0.75 * p.hertz_factor,
                    r_eff: r_max,
                    work: a.work,
                }
                .critical_separation()
            })
        })
        .fold(0.0, f64::max)
}

fn unit(v: [f64; 3]) -> [f64; 3] {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    [v[0] / n, v[1] / n, v[2] / n]
}

/// Origin and unit vector of an axis-parallel line through `center` (the two coordinates
/// other than the axis, in x, y, z order).
fn axis_line(axis: Axis, center: [f64; 2]) -> ([f64; 3], [f64; 3]) {
    let a = axis.index();
    let mut origin = [0.0; 3];
    let mut dir = [0.0; 3];
    dir[a] = 1.0;
    let others = axis.others();
    origin[others[0]] = center[0];
    origin[others[1]] = center[1];
    (origin, dir)
}

const FAR: f64 = 1.0e12;

/// Walls of the scene (a box becomes its six inward-facing planes).
pub fn walls(scene: &Scene, material_index: &dyn Fn(&str) -> u16) -> Walls {
    let mut list = Vec::new();
    for (k, w) in scene.walls.iter().enumerate() {
        let default_name = format!("walls[{k}]");
        match w {
            WallSpec::Plane {
                name,
                material,
                point,
                normal,
                remove_at,
            } => list.push(Wall {
                name: name.clone().unwrap_or(default_name),
                shape: WallShape::Plane {
                    point: *point,
                    normal: unit(*normal),
                },
                material: material_index(material),
                remove_at: *remove_at,
                active: true,
            }),
            WallSpec::Box {
                name,
                material,
                min,
                max,
            } => {
                for d in 0..3 {
                    for (side, point, sign) in [("min", *min, 1.0), ("max", *max, -1.0)] {
                        let mut normal = [0.0; 3];
                        normal[d] = sign;
                        list.push(Wall {
                            name: format!(
                                "{}.{side}{}",
                                name.clone().unwrap_or(default_name.clone()),
                                ["x", "y", "z"][d]
                            ),
                            shape: WallShape::Plane { point, normal },
                            material: material_index(material),
                            remove_at: None,
                            active: true,
                        });
                    }
                }
            }
            WallSpec::Cylinder {
                name,
                material,
                axis,
                center,
                radius,
                bottom,
                top,
            } => {
                let (origin, dir) = axis_line(*axis, *center);
                list.push(Wall {
                    name: name.clone().unwrap_or(default_name),
                    shape: WallShape::Revolution {
                        origin,
                        axis: dir,
                        r0: *radius,
                        h0: bottom.unwrap_or(-FAR),
                        r1: *radius,
                        h1: top.unwrap_or(FAR),
                        thickness: 0.0,
                    },
                    material: material_index(material),
                    remove_at: None,
                    active: true,
                });
            }
            WallSpec::Pipe {
                name,
                material,
                axis,
                center,
                inner_radius,
                outer_radius,
                bottom,
                top,
                ..
            } => {
                let (origin, dir) = axis_line(*axis, *center);
                let radius = 0.5 * (inner_radius + outer_radius);
                list.push(Wall {
                    name: name.clone().unwrap_or(default_name),
                    shape: WallShape::Revolution {
                        origin,
                        axis: dir,
                        r0: radius,
                        h0: *bottom,
                        r1: radius,
                        h1: *top,
                        thickness: outer_radius - inner_radius,
                    },
                    material: material_index(material),
                    remove_at: None,
                    active: true,
                });
            }
            WallSpec::Cone {
                name,
                material,
                axis,
                center,
                radius_bottom,
                radius_top,
                bottom,
                top,
            } => {
                let (origin, dir) = axis_line(*axis, *center);
                list.push(Wall {
                    name: name.clone().unwrap_or(default_name),
                    shape: WallShape::Revolution {
                        origin,
                        axis: dir,
                        r0: *radius_bottom,
                        h0: *bottom,
                        r1: *radius_top,
                        h1: *top,
                        thickness: 0.0,
                    },
                    material: material_index(material),
                    remove_at: None,
                    active: true,
                });
            }
        }
    }
    Walls { list }
}

/// Largest radius of every particle source of the scene (placed and inflowing).
pub fn largest_radius(scene: &Scene, particles: &Particles) -> f64 {
    let placed = particles.radius.iter().copied().fold(0.0, f64::max);
    scene
        .inflows
        .iter()
        .flat_map(|i| i.radii.iter().copied())
        .fold(placed, f64::max)
}

/// Build the world of `scene` (read from `path`).
pub fn world_from_scene(scene: &Scene, path: &Path) -> Result<World, SceneError> {
    let err = |field: String, message: String| SceneError {
        file: path.to_path_buf(),
        field,
        message,
    };
    let materials_list: Vec<Material> = scene
        .materials
        .iter()
        .map(|m| Material {
            name: m.name.clone(),
            density: m.density,
            youngs_modulus: m.youngs_modulus,
            poisson_ratio: m.poisson_ratio,
            damping: match m.restitution {
                Some(e) => DampingLaw::Restitution(e),
                None => DampingLaw::Constant(m.normal_damping.unwrap_or(0.0)),
            },
        })
        .collect();
    let mut pairs = Vec::new();
    for a in &materials_list {
        for b in &materials_list {
            pairs.push(pair_params(a, b).map_err(|m| err("materials".into(), m))?);
        }
    }
    let material_index = |name: &str| -> u16 {
        scene
            .materials
            .iter()
            .position(|m| m.name == name)
            .expect("validated material name") as u16
    };
    if let Some(available) = crate::memory::available_memory() {
        crate::memory::check_fits(&crate::memory::scene_memory(scene), available, path)?;
    }
    let flow = match &scene.fluid {
        Some(f) => crate::fluid::fluid_grid(f, path)?
            .map(|grid| crate::fluid::fluid_flow(f, &grid, scene.simulation.gravity)),
        None => None,
    };
    let rho_f = scene.fluid.as_ref().map_or(0.0, |f| f.density);
    let g = scene.simulation.gravity;
    let body = BodyAcceleration {
        per_material: materials_list
            .iter()
            .map(|m| g.map(|gd| gd * (1.0 - rho_f / m.density)))
            .collect(),
    };
    let walls = walls(scene, &material_index);
    let (particles, clumps) =
        place_particles(scene, path, &walls, &materials_list, &material_index)?;
    // Every particle must start on the particle side of every wall.
    for i in 0..particles.len() {
        let p = [
            particles.position[0][i],
            particles.position[1][i],
            particles.position[2][i],
        ];
        for w in &walls.list {
            if wall_contains(&w.shape, p) == Some(false) {
                return Err(err(
                    source_field(scene, i),
                    format!("particle {} at {p:?} is outside wall `{}`: expected every particle inside all walls", particles.id[i], w.name),
                ));
            }
        }
    }
    // Every particle of a coupled scene must start where the fluid grid represents it.
    if let Some(flow) = &flow {
        if let Some((i, what)) = outside_the_fluid(flow.solver.grid(), &particles) {
            return Err(err(
                source_field(scene, i),
                format!("{what}: expected every particle inside the fluid box"),
            ));
        }
    }
    let r_max = largest_radius(scene, &particles);
    let laws = contact_laws(scene, &materials_list);
    let adhesive_reach = laws
        .as_ref()
        .map_or(0.0, |l| largest_critical_separation(l, &pairs, r_max));
    let lubrication = flow
        .as_ref()
        .and_then(|flow| lubrication_settings(scene, flow.solver.grid(), &particles));
    if let Some(l) = lubrication.filter(|l| l.roughness >= l.range) {
        return Err(err(
            "coupling.lubrication_roughness".into(),
            format!(
                "expected a gap below the lubrication range {:.3e} m (the fluid cell size unless `lubrication_range` is given), got {}",
                l.range, l.roughness
            ),
        ));
    }
    let lubrication_reach = lubrication.map_or(0.0, |l| l.range);
    let skin = match scene.neighbour.skin {
        Some(skin) if skin <= lubrication_reach => {
            return Err(err(
                "neighbour.skin".into(),
                format!(
                    "expected a skin > {lubrication_reach:.3e} m, the coupling's lubrication range (every pair it acts on must be in the Verlet list; the list is rebuilt when a particle may have moved half the difference), got {skin}"
                ),
            ))
        }
        Some(skin) if skin <= adhesive_reach => {
            return Err(err(
                "neighbour.skin".into(),
                format!(
                    "expected a skin > {adhesive_reach:.3e} m, the largest JKR critical separation of the scene's adhesive pairs (a stretched adhesive contact must stay in the Verlet list), got {skin}"
                ),
            ))
        }
        Some(skin) => skin,
        None => (0.2 * r_max.max(f64::MIN_POSITIVE)).max(2.0 * adhesive_reach) + lubrication_reach,
    };
    let mut world = World::new();
    world.insert_resource(SimClock::new(scene.simulation.dt));
    world.insert_resource(Materials {
        list: materials_list,
        pairs,
    });
    world.insert_resource(body);
    world.insert_resource(NeighbourSettings {
        skin,
        reach: lubrication_reach,
        sort_every: scene.neighbour.sort_every.unwrap_or(1),
    });
    world.insert_resource(VerletList {
        stale: true,
        ..Default::default()
    });
    world.insert_resource(Reorder::default());
    world.insert_resource(StepMotion::default());
    world.insert_resource(RunHealth {
        overlap_limit: scene.simulation.overlap_limit,
        ..Default::default()
    });
    if !walls.list.is_empty() {
        world.insert_resource(walls);
        world.insert_resource(WallList::default());
    }
    let damped = scene.materials.iter().any(|m| {
        m.restitution.is_some_and(|e| e < 1.0) || m.normal_damping.is_some_and(|d| d > 0.0)
    });
    // A scene without particles (a flow only) runs no DEM system.
    let integrator = scene.has_particles().then_some(scene.simulation.integrator);
    match integrator {
        None => {}
        Some(crate::scene::IntegratorName::Gear) => {
            world.insert_resource(IntegratorKind::Gear);
            let mut gear = GearState {
                alpha0: if damped { 19.0 / 90.0 } else { 19.0 / 120.0 },
                ..Default::default()
            };
            gear.resize_rows(particles.len());
            world.insert_resource(gear);
        }
        Some(crate::scene::IntegratorName::VelocityVerlet) => {
            world.insert_resource(IntegratorKind::VelocityVerlet);
            let mut state = VerletState::default();
            state.resize_rows(particles.len());
            world.insert_resource(state);
        }
    }
    if let Some(laws) = laws {
        let width = laws.layout.width;
        world.insert_resource(ContactHistory {
            width,
            directed: laws.layout.spring,
            ..Default::default()
        });
        if world.contains_resource::<Walls>() {
            world.insert_resource(WallHistory {
                width,
                ..Default::default()
            });
        }
        if laws.has_torques() {
            insert_rotation(&mut world, particles.len());
        }
        world.insert_resource(laws);
    }
    if let Some(mut flow) = flow {
        if let Some((n_s, _)) = scene.subcycling {
            flow.solver.set_project_markers(true);
            insert_coupling(&mut world, scene, n_s, particles.len());
            if let Some(lubrication) = lubrication {
                world.insert_resource(lubrication);
            }
        }
        world.insert_resource(flow);
    }
    if scene.spheres.iter().any(|s| s.fixed) {
        let mut clamped = Clamped::default();
        clamped.resize_rows(particles.len());
        // Spheres come first in load order, so sphere k is row k.
        for (k, sphere) in scene.spheres.iter().enumerate() {
            clamped.held[k] = sphere.fixed;
            for d in 0..3 {
                clamped.origin[d][k] = sphere.position[d];
                clamped.velocity[d][k] = sphere.velocity[d];
            }
        }
        world.insert_resource(clamped);
    }
    if !scene.inflows.is_empty() {
        let mut seed = scene.simulation.seed ^ 0x005E_ED0F_1F10;
        let list = scene
            .inflows
            .iter()
            .map(|i| {
                // A clump inflow: the type's material, its bounding radius for the sites.
                let clump = i.clump.as_ref().map(|c| {
                    crate::clumps::type_index(&scene.clump_types, c).expect("validated") as u16
                });
                let (material, radii, fractions) = match (clump, &clumps) {
                    (Some(k), Some(c)) => {
                        let ty = &c.types[k as usize];
                        let reach = ty.bounding_radius();
                        (ty.material, vec![reach], vec![1.0])
                    }
                    _ => (
                        material_index(i.material.as_deref().expect("validated inflow")),
                        i.radii.clone(),
                        i.fractions.clone(),
                    ),
                };
                Inflow {
                    material,
                    clump,
                    rate: i.rate,
                    start: i.start,
                    stop: i.stop.unwrap_or(f64::INFINITY),
                    total: i.total,
                    interval: i.interval.unwrap_or(0.01),
                    region: match i.region {
                        RegionSpec::Box { min, max } => InflowRegion::Box { min, max },
                        RegionSpec::Cylinder {
                            center,
                            radius,
                            bottom,
                            top,
                        } => InflowRegion::CylinderZ {
                            center,
                            radius,
                            z_min: bottom,
                            z_max: top,
                        },
                    },
                    radii,
                    fractions,
                    velocity: i.velocity,
                    velocity_jitter: i.velocity_jitter,
                    inserted: 0,
                    next_time: i.start,
                    rng_state: {
                        seed = seed.wrapping_add(0x9E37_79B9);
                        seed
                    },
                }
            })
            .collect();
        world.insert_resource(Inflows {
            list,
            next_id: particles.len() as u32,
        });
    }
    if integrator.is_some() && !scene.sinks.is_empty() {
        let list = scene
            .sinks
            .iter()
            .enumerate()
            .map(|(k, sink)| {
                let len = sink.normal.iter().map(|x| x * x).sum::<f64>().sqrt();
                Sink {
                    name: sink.name.clone().unwrap_or_else(|| format!("sink {k}")),
                    point: sink.point,
                    normal: sink.normal.map(|x| x / len),
                    radius: sink.radius.unwrap_or(f64::INFINITY),
                }
            })
            .collect();
        world.insert_resource(Sinks::new(list));
    }
    if integrator.is_some() {
        // The balance holds where only contacts and the body acceleration act: no flow
        // doing work, no particles moved on a path, no adhesion (its surface energy is
        // not counted).
        let adhesive = world
            .get_resource::<ContactLaws>()
            .is_some_and(|l| l.pairs.iter().any(|p| p.adhesion.is_some()));
        world.insert_resource(EnergyBalance {
            enforced: !world.contains_resource::<Coupling>()
                && !world.contains_resource::<Clamped>()
                && !adhesive,
            tolerance: scene.simulation.energy_growth_limit,
            ..Default::default()
        });
    }
    if let Some(clumps) = clumps {
        world.insert_resource(clumps);
    }
    world.insert_resource(particles);
    Ok(world)
}

/// The coupling data of a scene with a fluid grid and particles: parameters, cell
/// markers, held hydrodynamic forces, and rotation (hydrodynamic torques turn the
/// particles even when no contact law does).
fn insert_coupling(world: &mut World, scene: &Scene, n_s: u32, rows: usize) {
    let spec = scene.coupling.clone().unwrap_or_default();
    let fluid = scene.fluid.as_ref().expect("coupled scene has a fluid");
    world.insert_resource(Coupling {
        fluid_density: fluid.density,
        viscosity: fluid.viscosity.expect("validated"),
        alpha: spec.alpha,
        method: match spec.force {
            ForceMethodName::SurfacePoints => ForceMethod::SurfacePoints,
            ForceMethodName::VolumeIntegral => ForceMethod::VolumeIntegral,
        },
        update: match spec.update {
            ParticleUpdateName::FluidMomentum => ParticleUpdate::FluidMomentum,
            ParticleUpdateName::Prescribed => ParticleUpdate::Prescribed,
        },
        inside: match spec.inside_fluid {
            InsideFluidName::Particle => InsideFluid::Particle,
            InsideFluidName::Fluid => InsideFluid::Fluid,
        },
        boundary: match spec.boundary {
            BoundaryRuleName::FaceCentre => BoundaryRule::FaceCentre,
            BoundaryRuleName::DistancePenalty => BoundaryRule::DistancePenalty,
        },
        rule: grainflow_systems::coupling::lebedev::lebedev_rule(spec.points)
            .expect("validated rule"),
        subcycles: n_s,
    });
    world.insert_resource(CellMarkers::default());
    let mut hydro = HydroForces::default();
    hydro.resize_rows(rows);
    world.insert_resource(hydro);
    if !world.contains_resource::<Rotation>() {
        insert_rotation(world, rows);
    }
}

/// The lubrication correction of a coupled scene that asks for it: the fluid's dynamic
/// viscosity, the range (default: the smallest side of a fluid cell) and the roughness
/// (default: 1 % of the smallest particle radius, at most half the range).
fn lubrication_settings(
    scene: &Scene,
    grid: &grainflow_fluid::Grid,
    particles: &Particles,
) -> Option<Lubrication> {
    let spec = scene.coupling.as_ref().filter(|c| c.lubrication)?;
    let fluid = scene.fluid.as_ref()?;
    let h = grid.h();
    let r_min = particles
        .radius
        .iter()
        .copied()
        .fold(f64::INFINITY, f64::min);
    let range = spec.lubrication_range.unwrap_or(h[0].min(h[1]).min(h[2]));
    Some(Lubrication {
        viscosity: fluid.density * fluid.viscosity?,
        range,
        roughness: spec
            .lubrication_roughness
            .unwrap_or((0.01 * r_min).min(0.5 * range)),
    })
}

/// Rotational state for `rows` particles, with the integrator's extra columns.
fn insert_rotation(world: &mut World, rows: usize) {
    let kind = *world
        .get_resource::<IntegratorKind>()
        .expect("rotation needs particles and an integrator");
    let mut rotation = Rotation {
        aux: vec![Default::default(); grainflow_systems::integrate::rotation::aux_columns(kind)],
        ..Default::default()
    };
    rotation.resize_rows(rows);
    world.insert_resource(rotation);
}

/// The scene field a particle (by load order) came from, for error messages.
fn source_field(scene: &Scene, i: usize) -> String {
    if i < scene.spheres.len() {
        return format!("spheres[{i}]");
    }
    if !scene.blocks.is_empty() && scene.lammps.is_empty() {
        return "blocks".into();
    }
    if scene.blocks.is_empty() && !scene.lammps.is_empty() {
        return "lammps".into();
    }
    "blocks/lammps".into()
}

fn place_particles(
    scene: &Scene,
    path: &Path,
    walls: &Walls,
    materials: &[Material],
    material_index: &dyn Fn(&str) -> u16,
) -> Result<(Particles, Option<Clumps>), SceneError> {
    let mut p = Particles::default();
    let mut next_id = 0u32;
    for s in &scene.spheres {
        let m = material_index(&s.material);
        p.push(NewParticle {
            id: next_id,
            material: m,
            radius: s.radius,
            density: materials[m as usize].density,
            position: s.position,
            velocity: s.velocity,
            angular_velocity: s.angular_velocity,
        });
        next_id += 1;
    }
    let uses_clumps = !scene.clumps.is_empty()
        || scene.blocks.iter().any(|b| b.clump.is_some())
        || scene.inflows.iter().any(|i| i.clump.is_some());
    let mut clumps = uses_clumps.then(|| Clumps {
        types: crate::clumps::clump_types(&scene.clump_types, materials, material_index),
        ..Default::default()
    });
    let mut rng = scene.simulation.seed;
    if let Some(clumps) = &mut clumps {
        let mut orientations = scene.simulation.seed ^ 0x0C1D_0B0D;
        for c in &scene.clumps {
            let kind = crate::clumps::type_index(&scene.clump_types, &c.kind).expect("validated");
            let q = crate::clumps::spec_orientation(c, &mut orientations);
            let state = crate::clumps::spec_state(c);
            grainflow_systems::integrate::rigid_body::insert_clump(
                clumps,
                &mut p,
                kind as u16,
                q,
                state,
                &mut next_id,
            );
        }
    }
    for b in &scene.blocks {
        // A block of spheres of one radius, or of clumps of one type (reach: the bounding
        // radius about the centre of mass).
        let kind = b
            .clump
            .as_ref()
            .map(|c| crate::clumps::type_index(&scene.clump_types, c).expect("validated") as u16);
        let (m, reach) = match (kind, &clumps) {
            (Some(k), Some(c)) => {
                let ty = &c.types[k as usize];
                let reach = ty.bounding_radius();
                (ty.material, reach)
            }
            _ => (
                material_index(b.material.as_deref().expect("validated block")),
                b.radius.expect("validated block"),
            ),
        };
        let a = b.spacing.unwrap_or(2.1 * reach);
        let amp = b.jitter * 0.5 * (a - 2.0 * reach).max(0.0);
        let n = [0, 1, 2].map(|d| ((b.max[d] - b.min[d]) / a).floor() as usize + 1);
        let mut placed = 0u64;
        'sites: for iz in 0..n[2] {
            for iy in 0..n[1] {
                for ix in 0..n[0] {
                    if b.count.is_some_and(|c| placed >= c) {
                        break 'sites;
                    }
                    let mut pos = [
                        b.min[0] + ix as f64 * a,
                        b.min[1] + iy as f64 * a,
                        b.min[2] + iz as f64 * a,
                    ];
                    for c in pos.iter_mut() {
                        *c += amp * (2.0 * next_f64(&mut rng) - 1.0);
                    }
                    if b.inside_walls
                        && walls.list.iter().any(|w| {
                            let (dist, _) = wall_distance(&w.shape, pos);
                            dist < reach || wall_contains(&w.shape, pos) == Some(false)
                        })
                    {
                        continue;
                    }
                    match (kind, &mut clumps) {
                        (Some(k), Some(clumps)) => {
                            let q =
                                grainflow_systems::integrate::rigid_body::random_rotation(&mut rng);
                            let state = BodyState {
                                position: glam::DVec3::from_array(pos),
                                velocity: glam::DVec3::from_array(b.velocity),
                                orientation: glam::DQuat::IDENTITY,
                                angular_velocity: glam::DVec3::ZERO,
                            };
                            grainflow_systems::integrate::rigid_body::insert_clump(
                                clumps,
                                &mut p,
                                k,
                                q,
                                state,
                                &mut next_id,
                            );
                        }
                        _ => {
                            p.push(NewParticle {
                                id: next_id,
                                material: m,
                                radius: reach,
                                density: materials[m as usize].density,
                                position: pos,
                                velocity: b.velocity,
                                angular_velocity: [0.0; 3],
                            });
                            next_id += 1;
                        }
                    }
                    placed += 1;
                }
            }
        }
    }
    for (k, l) in scene.lammps.iter().enumerate() {
        let m = material_index(&l.material);
        let atoms = crate::lammps::read_data(&l.file).map_err(|e| SceneError {
            file: path.to_path_buf(),
            field: format!("lammps[{k}].file"),
            message: e,
        })?;
        for atom in atoms {
            p.push(NewParticle {
                id: next_id,
                material: m,
                radius: atom.radius,
                density: materials[m as usize].density,
                position: atom.position,
                velocity: atom.velocity,
                angular_velocity: atom.angular_velocity,
            });
            next_id += 1;
        }
    }
    Ok((p, clumps))
}
