//! Particle output: `particles.h5` (one group `/step_NNNNNNNN` per output time, rows in
//! stable id order) and the `particles.xdmf` sidecar that ParaView opens. The XDMF file is
//! rewritten after every frame, so a run that stops early leaves readable output.
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use bevy_ecs::prelude::*;
use grainflow_components::{Particles, RunHealth, SimClock};

/// One written frame.
#[derive(Debug, Clone)]
pub struct Frame {
    pub step: u64,
    pub time: f64,
    pub particles: usize,
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
}

impl ParticleOutput {
    pub fn create(dir: &Path, interval: f64) -> Result<Self, String> {
        std::fs::create_dir_all(dir)
            .map_err(|e| format!("cannot create output directory {}: {e}", dir.display()))?;
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
        })
    }

    /// Write the particles as frame `clock.step`, rows sorted by id.
    pub fn write_frame(&mut self, particles: &Particles, clock: &SimClock) -> Result<(), String> {
        if self.frames.last().is_some_and(|f| f.step == clock.step) {
            return Ok(());
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
        self.file.flush().map_err(h5)?;
        self.frames.push(Frame {
            step: clock.step,
            time: clock.time,
            particles: n,
        });
        self.write_xdmf()
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
    clock: Res<SimClock>,
    health: Res<RunHealth>,
    mut out: ResMut<ParticleOutput>,
) {
    if health.failure.is_some() || out.error.is_some() || out.interval <= 0.0 {
        return;
    }
    if clock.time + 0.5 * clock.dt >= out.next_time {
        out.next_time += out.interval;
        while out.next_time <= clock.time {
            out.next_time += out.interval;
        }
        if let Err(e) = out.write_frame(&particles, &clock) {
            out.error = Some(e);
        }
    }
}
