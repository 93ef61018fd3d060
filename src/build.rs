//! From a scene to an ECS world: materials, walls, particles, and the resources the
//! registered systems need. Systems a scene does not use get no resources.
use std::path::Path;

use bevy_ecs::prelude::World;
use grainflow_components::*;
use grainflow_systems::inflow::next_f64;
use grainflow_systems::walls::{wall_contains, wall_distance};

use crate::scene::{Axis, RegionSpec, Scene, SceneError, WallSpec};

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
    let others: Vec<usize> = (0..3).filter(|&d| d != a).collect();
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
    let rho_f = scene.fluid.as_ref().map_or(0.0, |f| f.density);
    let g = scene.simulation.gravity;
    let body = BodyAcceleration {
        per_material: materials_list
            .iter()
            .map(|m| g.map(|gd| gd * (1.0 - rho_f / m.density)))
            .collect(),
    };
    let walls = walls(scene, &material_index);
    let particles = place_particles(scene, path, &walls, &materials_list, &material_index)?;
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
    let r_max = largest_radius(scene, &particles);
    let mut world = World::new();
    world.insert_resource(SimClock::new(scene.simulation.dt));
    world.insert_resource(Materials {
        list: materials_list,
        pairs,
    });
    world.insert_resource(body);
    world.insert_resource(NeighbourSettings {
        skin: scene
            .neighbour
            .skin
            .unwrap_or(0.2 * r_max.max(f64::MIN_POSITIVE)),
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
    match scene.simulation.integrator {
        crate::scene::IntegratorName::Gear => {
            world.insert_resource(IntegratorKind::Gear);
            let mut gear = GearState {
                alpha0: if damped { 19.0 / 90.0 } else { 19.0 / 120.0 },
                ..Default::default()
            };
            gear.resize_rows(particles.len());
            world.insert_resource(gear);
        }
        crate::scene::IntegratorName::VelocityVerlet => {
            world.insert_resource(IntegratorKind::VelocityVerlet);
            let mut state = VerletState::default();
            state.resize_rows(particles.len());
            world.insert_resource(state);
        }
    }
    if !scene.inflows.is_empty() {
        let mut seed = scene.simulation.seed ^ 0x005E_ED0F_1F10;
        let list = scene
            .inflows
            .iter()
            .map(|i| Inflow {
                material: material_index(&i.material),
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
                radii: i.radii.clone(),
                fractions: i.fractions.clone(),
                velocity: i.velocity,
                velocity_jitter: i.velocity_jitter,
                inserted: 0,
                next_time: i.start,
                rng_state: {
                    seed = seed.wrapping_add(0x9E37_79B9);
                    seed
                },
            })
            .collect();
        world.insert_resource(Inflows {
            list,
            next_id: particles.len() as u32,
        });
    }
    world.insert_resource(particles);
    Ok(world)
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
) -> Result<Particles, SceneError> {
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
    let mut rng = scene.simulation.seed;
    for b in &scene.blocks {
        let m = material_index(&b.material);
        let a = b.spacing.unwrap_or(2.1 * b.radius);
        let amp = b.jitter * 0.5 * (a - 2.0 * b.radius);
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
                            dist < b.radius || wall_contains(&w.shape, pos) == Some(false)
                        })
                    {
                        continue;
                    }
                    p.push(NewParticle {
                        id: next_id,
                        material: m,
                        radius: b.radius,
                        density: materials[m as usize].density,
                        position: pos,
                        velocity: b.velocity,
                        angular_velocity: [0.0; 3],
                    });
                    next_id += 1;
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
    Ok(p)
}
