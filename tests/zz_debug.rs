mod common;
use common::*;
use grainflow_components::*;
#[test]
fn dbg() {
    let text = std::fs::read_to_string("/tmp/dbg/falling.toml").unwrap();
    let mut sim = simulation(&text, "falling.toml");
    for k in 0..10 {
        sim.step();
        let p = sim.world.resource::<Particles>();
        let i = p.id.iter().position(|&x| x == 283).unwrap();
        let h = sim.world.resource::<RunHealth>();
        eprintln!("step {k}: pos {:?} {:?} {:?} v {:?} f {:?} r {} ratio {} {}", p.position[0][i], p.position[1][i], p.position[2][i], p.velocity[2][i], p.force[2][i], p.radius[i], h.max_overlap_ratio, h.max_overlap_particle);
    }
}
