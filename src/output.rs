//! Output: `particles.h5` (one group `/step_NNNNNNNN` per output time, rows in stable id
//! order) and the `particles.xdmf` sidecar that ParaView opens; with a fluid grid also
//! `fluid.h5` (the same groups: cell-centred `velocity` and `pressure`) and `fluid.xdmf`
//! (a structured grid, `3DCoRectMesh`). The XDMF files are rewritten after every frame,
//! so a run that stops early leaves readable output.
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use bevy_ecs::prelude::*;
use grainflow_components::{Clumps, Particles, RunHealth, SimClock};
use grainflow_fluid::Grid;
use grainflow_systems::fluid::FluidFlow;

/// One written frame.
#[derive(Debug, Clone)]
pub struct Frame {
    pub step: u64,
    pub time: f64,
    pub particles: usize,
    /// Whether the frame has the clump datasets (`orientation`, `clump`).
    pub clumps: bool,
}

/// The open output file and the output timetable.
#[derive(Resource)]
pub struct ParticleOutput {
    pub dir: PathBuf,
    pub file: hdf5::File,
    pub frames: Vec<Frame>,
    pub interval: f64,
    pub next_time: f64,
    pub error: Option<String>,
    /// `fluid.h5`, opened at the first frame of a run with a fluid grid.
    pub fluid: Option<hdf5::File>,
}

/// The files `grainflow run` writes into its output directory; a run removes those of an
/// earlier run first, and no other file.
pub const RUN_FILES: [&str; 7] = [
    "particles.h5",
    "particles.xdmf",
    "fluid.h5",
    "fluid.xdmf",
    "coupling.csv",
    "sinks.csv",
    "summary.json",
];

impl ParticleOutput {
    /// Whether the writer writes a frame at the end of the step that reaches simulated
    /// `time` (time step `dt`).
    pub fn due(&self, time: f64, dt: f64) -> bool {
        self.interval > 0.0 && time + 0.5 * dt >= self.next_time
    }

    /// Create `dir` if missing and remove the files of an earlier run in it
    /// ([`RUN_FILES`]), then start `particles.h5`.
    pub fn create(dir: &Path, interval: f64) -> Result<Self, String> {
        std::fs::create_dir_all(dir)
            .map_err(|e| format!("cannot create output directory {}: {e}", dir.display()))?;
        for name in RUN_FILES {
            let path = dir.join(name);
            match std::fs::remove_file(&path) {
                Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                    return Err(format!(
                        "cannot remove {} of an earlier run: {e}",
                        path.display()
                    ))
                }
                _ => {}
            }
        }
        let path = dir.join("particles.h5");
        let file = hdf5::File::create(&path)
            .map_err(|e| format!("cannot create {}: {e}", path.display()))?;
        Ok(Self {
            dir: dir.to_path_buf(),
            file,
            frames: Vec::new(),
            interval,
            next_time: 0.0,
            error: None,
            fluid: None,
        })
    }

    /// Open the `particles.h5` of an earlier run in `dir` to append to it, with the frames
    /// it holds, in step order.
    pub fn reopen(dir: &Path, interval: f64) -> Result<Self, String> {
        let path = dir.join("particles.h5");
        let bad = |e: hdf5::Error| format!("cannot read {}: {e}", path.display());
        let file = hdf5::File::open_rw(&path).map_err(bad)?;
        let mut frames = Vec::new();
        for name in file.member_names().map_err(bad)? {
            let Some(step) = name
                .strip_prefix("step_")
                .and_then(|n| n.parse::<u64>().ok())
            else {
                continue;
            };
            let group = file.group(&name).map_err(bad)?;
            frames.push(Frame {
                step,
                time: group
                    .attr("time")
                    .and_then(|a| a.read_scalar())
                    .map_err(bad)?,
                particles: group.dataset("id").map_err(bad)?.size(),
                clumps: group.link_exists("orientation"),
            });
        }
        frames.sort_by_key(|f| f.step);
        let fluid_path = dir.join("fluid.h5");
        let fluid = if fluid_path.is_file() {
            Some(
                hdf5::File::open_rw(&fluid_path)
                    .map_err(|e| format!("cannot read {}: {e}", fluid_path.display()))?,
            )
        } else {
            None
        };
        Ok(Self {
            dir: dir.to_path_buf(),
            file,
            frames,
            interval,
            next_time: 0.0,
            error: None,
            fluid,
        })
    }

    /// Keep the first `count` frames: the later ones are removed from the files
    /// (particles.h5 and fluid.h5) and from the particles' XDMF index (the flow's is
    /// rewritten by [`ParticleOutput::write_fluid_xdmf`], which needs the grid).
    pub fn keep_frames(&mut self, count: usize) -> Result<(), String> {
        if count > self.frames.len() {
            return Err(format!(
                "the checkpoint counts {count} frames, particles.h5 holds {}",
                self.frames.len()
            ));
        }
        for f in self.frames.drain(count..) {
            let name = format!("step_{:08}", f.step);
            self.file
                .unlink(&name)
                .map_err(|e| format!("removing a frame from particles.h5: {e}"))?;
            if let Some(fluid) = self.fluid.as_ref().filter(|h5| h5.link_exists(&name)) {
                fluid
                    .unlink(&name)
                    .map_err(|e| format!("removing a frame from fluid.h5: {e}"))?;
            }
        }
        if let Some(fluid) = &self.fluid {
            fluid
                .flush()
                .map_err(|e| format!("writing fluid.h5: {e}"))?;
        }
        self.file
            .flush()
            .map_err(|e| format!("writing particles.h5: {e}"))?;
        self.write_xdmf()
    }

    /// Write the particles as frame `clock.step`, rows sorted by id, and the flow when
    /// there is one. With clumps, also every row's orientation (its body's, as a
    /// quaternion w, x, y, z of the scene's body frame; free spheres the identity), its
    /// body's `axis` (the principal axis of the smallest moment, the long axis of an
    /// elongated clump, in the world; zero for free spheres: the field ParaView glyphs)
    /// and body (`clump`: the body index, `u32::MAX` for a free sphere).
    pub fn write_frame(
        &mut self,
        particles: &Particles,
        clumps: Option<&Clumps>,
        flow: Option<&FluidFlow>,
        clock: &SimClock,
    ) -> Result<(), String> {
        if self.frames.last().is_some_and(|f| f.step == clock.step) {
            return Ok(());
        }
        if let Some(flow) = flow {
            self.write_fluid_frame(flow, clock)?;
        }
        let _span = tracing::info_span!("write_particles").entered();
        let n = particles.len();
        let mut order: Vec<u32> = (0..n as u32).collect();
        order.sort_unstable_by_key(|&k| particles.id[k as usize]);
        let vec3 = |cols: &[Vec<f64>; 3]| -> Vec<f64> {
            let mut out = Vec::with_capacity(3 * n);
            for &k in &order {
                out.extend([
                    cols[0][k as usize],
                    cols[1][k as usize],
                    cols[2][k as usize],
                ]);
            }
            out
        };
        let h5 = |e: hdf5::Error| format!("writing particles.h5: {e}");
        let group = self
            .file
            .create_group(&format!("step_{:08}", clock.step))
            .map_err(h5)?;
        group
            .new_attr::<f64>()
            .create("time")
            .map_err(h5)?
            .write_scalar(&clock.time)
            .map_err(h5)?;
        let ids: Vec<u32> = order.iter().map(|&k| particles.id[k as usize]).collect();
        group
            .new_dataset::<u32>()
            .shape([n])
            .create("id")
            .map_err(h5)?
            .write_raw(&ids)
            .map_err(h5)?;
        for (name, cols) in [
            ("position", &particles.position),
            ("velocity", &particles.velocity),
            ("angular_velocity", &particles.angular_velocity),
        ] {
            let data = vec3(cols);
            group
                .new_dataset::<f64>()
                .shape([n, 3])
                .create(name)
                .map_err(h5)?
                .write_raw(&data)
                .map_err(h5)?;
        }
        let radius: Vec<f64> = order
            .iter()
            .map(|&k| particles.radius[k as usize])
            .collect();
        group
            .new_dataset::<f64>()
            .shape([n])
            .create("radius")
            .map_err(h5)?
            .write_raw(&radius)
            .map_err(h5)?;
        if let Some(clumps) = clumps {
            let body: Vec<u32> = ids
                .iter()
                .map(|&id| {
                    clumps
                        .body_of_id
                        .get(id as usize)
                        .copied()
                        .unwrap_or(u32::MAX)
                })
                .collect();
            let mut orientation = Vec::with_capacity(4 * n);
            let mut axis = Vec::with_capacity(3 * n);
            for &b in &body {
                let (q, a) = match b {
                    u32::MAX => (glam::DQuat::IDENTITY, glam::DVec3::ZERO),
                    b => {
                        let (b, principal) = (b as usize, clumps.orientation[b as usize]);
                        let frame = clumps.types[clumps.kind[b] as usize].frame;
                        (principal * frame, principal * glam::DVec3::X)
                    }
                };
                orientation.extend([q.w, q.x, q.y, q.z]);
                axis.extend(a.to_array());
            }
            group
                .new_dataset::<f64>()
                .shape([n, 3])
                .create("axis")
                .map_err(h5)?
                .write_raw(&axis)
                .map_err(h5)?;
            group
                .new_dataset::<f64>()
                .shape([n, 4])
                .create("orientation")
                .map_err(h5)?
                .write_raw(&orientation)
                .map_err(h5)?;
            group
                .new_dataset::<u32>()
                .shape([n])
                .create("clump")
                .map_err(h5)?
                .write_raw(&body)
                .map_err(h5)?;
        }
        self.file.flush().map_err(h5)?;
        self.frames.push(Frame {
            step: clock.step,
            time: clock.time,
            particles: n,
            clumps: clumps.is_some(),
        });
        self.write_xdmf()?;
        match flow {
            Some(flow) => self.write_fluid_xdmf(flow.solver.grid()),
            None => Ok(()),
        }
    }

    /// The flow at cell centres: each velocity component is the mean of its six face
    /// values (every Q1~ basis function is 1/6 at the cell centre), the pressure is the
    /// cell's.
    fn write_fluid_frame(&mut self, flow: &FluidFlow, clock: &SimClock) -> Result<(), String> {
        let _span = tracing::info_span!("write_fluid").entered();
        let h5 = |e: hdf5::Error| format!("writing fluid.h5: {e}");
        if self.fluid.is_none() {
            let path = self.dir.join("fluid.h5");
            self.fluid = Some(
                hdf5::File::create(&path)
                    .map_err(|e| format!("cannot create {}: {e}", path.display()))?,
            );
        }
        let file = self.fluid.as_ref().expect("opened above");
        let solver = &flow.solver;
        let grid = solver.grid();
        let lay = grid.layout();
        let cells = grid.num_cells();
        let mut velocity = vec![0.0; 3 * cells];
        for c in 0..cells {
            let at = lay.cell_coords(c);
            for a in 0..3 {
                for f in [lay.face(a, at), lay.face(a, lay.upper(a, at))] {
                    for d in 0..3 {
                        velocity[3 * c + d] += solver.u[d][f] / 6.0;
                    }
                }
            }
        }
        let group = file
            .create_group(&format!("step_{:08}", clock.step))
            .map_err(h5)?;
        group
            .new_attr::<f64>()
            .create("time")
            .map_err(h5)?
            .write_scalar(&clock.time)
            .map_err(h5)?;
        group
            .new_dataset::<f64>()
            .shape([cells, 3])
            .create("velocity")
            .map_err(h5)?
            .write_raw(&velocity)
            .map_err(h5)?;
        group
            .new_dataset::<f64>()
            .shape([cells])
            .create("pressure")
            .map_err(h5)?
            .write_raw(&solver.p)
            .map_err(h5)?;
        file.flush().map_err(h5)
    }

    /// `fluid.xdmf`: the flow's frames, one per particle frame, on the grid `grid`.
    pub fn write_fluid_xdmf(&self, grid: &Grid) -> Result<(), String> {
        let [nx, ny, nz] = grid.n();
        let [hx, hy, hz] = grid.h();
        let [x0, y0, z0] = grid.lower;
        let mut x = String::new();
        x.push_str("<?xml version=\"1.0\" ?>\n<Xdmf Version=\"3.0\">\n <Domain>\n");
        x.push_str("  <Grid Name=\"fluid\" GridType=\"Collection\" CollectionType=\"Temporal\">\n");
        for &Frame { step, time, .. } in &self.frames {
            let g = format!("fluid.h5:/step_{step:08}");
            let _ = writeln!(x, "   <Grid Name=\"step_{step:08}\" GridType=\"Uniform\">");
            let _ = writeln!(x, "    <Time Value=\"{time:.17e}\"/>");
            let _ = writeln!(
                x,
                "    <Topology TopologyType=\"3DCoRectMesh\" Dimensions=\"{} {} {}\"/>",
                nz + 1,
                ny + 1,
                nx + 1
            );
            let _ = writeln!(x, "    <Geometry GeometryType=\"ORIGIN_DXDYDZ\">\n     <DataItem Dimensions=\"3\" Format=\"XML\">{z0:e} {y0:e} {x0:e}</DataItem>\n     <DataItem Dimensions=\"3\" Format=\"XML\">{hz:e} {hy:e} {hx:e}</DataItem>\n    </Geometry>");
            let _ = writeln!(x, "    <Attribute Name=\"velocity\" AttributeType=\"Vector\" Center=\"Cell\">\n     <DataItem Dimensions=\"{nz} {ny} {nx} 3\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">{g}/velocity</DataItem>\n    </Attribute>");
            let _ = writeln!(x, "    <Attribute Name=\"pressure\" AttributeType=\"Scalar\" Center=\"Cell\">\n     <DataItem Dimensions=\"{nz} {ny} {nx}\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">{g}/pressure</DataItem>\n    </Attribute>");
            x.push_str("   </Grid>\n");
        }
        x.push_str("  </Grid>\n </Domain>\n</Xdmf>\n");
        let path = self.dir.join("fluid.xdmf");
        std::fs::write(&path, x).map_err(|e| format!("cannot write {}: {e}", path.display()))
    }

    fn write_xdmf(&self) -> Result<(), String> {
        let mut x = String::new();
        x.push_str("<?xml version=\"1.0\" ?>\n<Xdmf Version=\"3.0\">\n <Domain>\n");
        x.push_str(
            "  <Grid Name=\"particles\" GridType=\"Collection\" CollectionType=\"Temporal\">\n",
        );
        for f in &self.frames {
            let g = format!("particles.h5:/step_{:08}", f.step);
            let n = f.particles;
            let _ = writeln!(
                x,
                "   <Grid Name=\"step_{:08}\" GridType=\"Uniform\">",
                f.step
            );
            let _ = writeln!(x, "    <Time Value=\"{:.17e}\"/>", f.time);
            let _ = writeln!(x, "    <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"{n}\" NodesPerElement=\"1\"/>");
            let _ = writeln!(x, "    <Geometry GeometryType=\"XYZ\">\n     <DataItem Dimensions=\"{n} 3\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">{g}/position</DataItem>\n    </Geometry>");
            for (name, kind, dims, ty, prec) in [
                ("id", "Scalar", format!("{n}"), "UInt", 4),
                ("radius", "Scalar", format!("{n}"), "Float", 8),
                ("velocity", "Vector", format!("{n} 3"), "Float", 8),
                ("angular_velocity", "Vector", format!("{n} 3"), "Float", 8),
            ] {
                let _ = writeln!(x, "    <Attribute Name=\"{name}\" AttributeType=\"{kind}\" Center=\"Node\">\n     <DataItem Dimensions=\"{dims}\" NumberType=\"{ty}\" Precision=\"{prec}\" Format=\"HDF\">{g}/{name}</DataItem>\n    </Attribute>");
            }
            if f.clumps {
                for (name, kind, dims, ty, prec) in [
                    ("orientation", "Matrix", format!("{n} 4"), "Float", 8),
                    ("axis", "Vector", format!("{n} 3"), "Float", 8),
                    ("clump", "Scalar", format!("{n}"), "UInt", 4),
                ] {
                    let _ = writeln!(x, "    <Attribute Name=\"{name}\" AttributeType=\"{kind}\" Center=\"Node\">\n     <DataItem Dimensions=\"{dims}\" NumberType=\"{ty}\" Precision=\"{prec}\" Format=\"HDF\">{g}/{name}</DataItem>\n    </Attribute>");
                }
            }
            x.push_str("   </Grid>\n");
        }
        x.push_str("  </Grid>\n </Domain>\n</Xdmf>\n");
        let path = self.dir.join("particles.xdmf");
        std::fs::write(&path, x).map_err(|e| format!("cannot write {}: {e}", path.display()))
    }
}

/// Output system: writes a frame when the output time has come and the step is healthy.
pub fn write_particles(
    particles: Res<Particles>,
    clumps: Option<Res<Clumps>>,
    flow: Option<Res<FluidFlow>>,
    clock: Res<SimClock>,
    health: Res<RunHealth>,
    mut out: ResMut<ParticleOutput>,
) {
    if health.failure.is_some() || out.error.is_some() || out.interval <= 0.0 {
        return;
    }
    if out.due(clock.time, clock.dt) {
        out.next_time += out.interval;
        while out.next_time <= clock.time {
            out.next_time += out.interval;
        }
        if let Err(e) = out.write_frame(&particles, clumps.as_deref(), flow.as_deref(), &clock) {
            out.error = Some(e);
        }
    }
}
