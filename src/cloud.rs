//! Observables of a cloud of spheres settling in a box (the seed's "Sedimentation of 64
//! spheres", with and without adhesion, and the particles of its lid-driven cavity),
//! computed from the particles' positions, radii and velocities alone, so that the same
//! functions serve the run (`summary.json` → `observables`, `src/observables.rs`) and
//! the plots of a run directory (`grainflow plot series --quantity settling-velocity |
//! clusters | resting`, `src/plot.rs`):
//!
//! * **settling velocity** of the cloud: the mean over the spheres of the velocity
//!   component along gravity, `U_s = (1/N) Σ v_i · ĝ` (positive when falling);
//! * **clusters**: spheres i, j are in contact when their surface gap
//!   `|x_i − x_j| − r_i − r_j` is below [`CONTACT_GAP_FRACTION`] times the smaller
//!   radius; the clusters are the connected groups of this relation (union-find), a lone
//!   sphere being a cluster of one;
//! * **resting**: a sphere rests when it is slower than the rest speed and its cluster
//!   touches the floor (some sphere of it within the contact gap of the floor, the side
//!   of the box that gravity points at most directly, [`Floor::side_index`]): it lies on
//!   the floor or on spheres that do;
//! * **landing time**: the first time every sphere rests, with the rest speed
//!   [`REST_SPEED_FRACTION`] of the largest settling velocity the cloud has reached so
//!   far ([`landing_time`]).

/// Contact gap of the cluster and resting tests, as a fraction of the smaller radius.
pub const CONTACT_GAP_FRACTION: f64 = 0.1;

/// Rest speed of [`landing_time`], as a fraction of the cloud's peak settling velocity.
pub const REST_SPEED_FRACTION: f64 = 0.05;

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

/// The unit vector along `g`; `None` for a zero (or non-finite) vector.
pub fn unit(g: [f64; 3]) -> Option<[f64; 3]> {
    let n = norm(g);
    (n > 0.0 && n.is_finite()).then(|| g.map(|c| c / n))
}

/// Union-find over `n` elements with path halving and union by size.
struct UnionFind {
    parent: Vec<usize>,
    size: Vec<usize>,
}

impl UnionFind {
    fn new(n: usize) -> Self {
        Self {
            parent: (0..n).collect(),
            size: vec![1; n],
        }
    }

    fn find(&mut self, mut i: usize) -> usize {
        while self.parent[i] != i {
            self.parent[i] = self.parent[self.parent[i]];
            i = self.parent[i];
        }
        i
    }

    fn union(&mut self, a: usize, b: usize) {
        let (mut a, mut b) = (self.find(a), self.find(b));
        if a == b {
            return;
        }
        if self.size[a] < self.size[b] {
            std::mem::swap(&mut a, &mut b);
        }
        self.parent[b] = a;
        self.size[a] += self.size[b];
    }
}

/// The cluster of every sphere: labels `0 .. count` (in the order of each cluster's
/// first sphere) and the count. Spheres are in contact when their gap is below
/// `gap_fraction` times the smaller radius. Pairs are found by a sweep along x (sorted
/// centres, each compared only with those within the largest contact reach).
pub fn clusters(position: &[[f64; 3]], radius: &[f64], gap_fraction: f64) -> (Vec<usize>, usize) {
    let n = position.len();
    assert_eq!(radius.len(), n, "one radius per position");
    let mut uf = UnionFind::new(n);
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| position[a][0].total_cmp(&position[b][0]));
    let r_max = radius.iter().copied().fold(0.0, f64::max);
    let reach = 2.0 * r_max + gap_fraction * r_max;
    for (k, &i) in order.iter().enumerate() {
        for &j in &order[k + 1..] {
            if position[j][0] - position[i][0] > reach {
                break;
            }
            let d = [0, 1, 2].map(|c| position[i][c] - position[j][c]);
            let gap = norm(d) - radius[i] - radius[j];
            if gap < gap_fraction * radius[i].min(radius[j]) {
                uf.union(i, j);
            }
        }
    }
    let mut label_of_root = vec![usize::MAX; n];
    let mut labels = Vec::with_capacity(n);
    let mut count = 0;
    for i in 0..n {
        let root = uf.find(i);
        if label_of_root[root] == usize::MAX {
            label_of_root[root] = count;
            count += 1;
        }
        labels.push(label_of_root[root]);
    }
    (labels, count)
}

/// The floor: the plane normal to the unit vector `down` (along gravity) at `level`
/// along it; a sphere's gap to it is `level − x · down − r`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Floor {
    pub down: [f64; 3],
    pub level: f64,
}

impl Floor {
    /// The six sides of the box `lower .. upper` as floors, in the order xmin, xmax,
    /// ymin, ymax, zmin, zmax.
    pub fn sides(lower: [f64; 3], upper: [f64; 3]) -> [Floor; 6] {
        std::array::from_fn(|s| {
            let (axis, high) = (s / 2, s % 2 == 1);
            let mut down = [0.0; 3];
            down[axis] = if high { 1.0 } else { -1.0 };
            let level = if high { upper[axis] } else { -lower[axis] };
            Floor { down, level }
        })
    }

    /// Which side of a box (index into [`Floor::sides`]) gravity along `down` points at
    /// most directly: the floor of the seed's cases, gravity along −z, is zmin.
    pub fn side_index(down: [f64; 3]) -> usize {
        let axis = (0..3)
            .max_by(|&a, &b| down[a].abs().total_cmp(&down[b].abs()))
            .expect("three axes");
        2 * axis + usize::from(down[axis] > 0.0)
    }

    /// Gap between the floor and a sphere at `x` of radius `r`.
    pub fn gap(&self, x: [f64; 3], r: f64) -> f64 {
        self.level - dot(x, self.down) - r
    }
}

/// How many spheres lie on the floor or on spheres that do: those in a cluster (`labels`
/// of [`clusters`]) of which some sphere's gap to the floor is below
/// [`CONTACT_GAP_FRACTION`] of its radius.
pub fn on_floor_count(
    position: &[[f64; 3]],
    radius: &[f64],
    labels: &[usize],
    floor: Floor,
) -> usize {
    let count = labels.iter().copied().max().map_or(0, |m| m + 1);
    let mut touches = vec![false; count];
    for ((&x, &r), &label) in position.iter().zip(radius).zip(labels) {
        if floor.gap(x, r) < CONTACT_GAP_FRACTION * r {
            touches[label] = true;
        }
    }
    labels.iter().filter(|&&l| touches[l]).count()
}

/// What the cloud observables need of one state of the spheres, whatever the direction
/// of gravity: mean velocity, largest speed, cluster count, and for each side of the box
/// (the order of [`Floor::sides`]) whether every sphere lies on it or on spheres that do.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CloudState {
    pub time: f64,
    pub mean_velocity: [f64; 3],
    pub max_speed: f64,
    pub clusters: usize,
    pub all_on_side: [bool; 6],
}

impl CloudState {
    /// The state of the spheres at `time` in the box `lower .. upper`.
    pub fn of(
        time: f64,
        position: &[[f64; 3]],
        radius: &[f64],
        velocity: &[[f64; 3]],
        (lower, upper): ([f64; 3], [f64; 3]),
    ) -> Self {
        let (labels, clusters) = clusters(position, radius, CONTACT_GAP_FRACTION);
        let n = position.len();
        let mean_velocity = if n == 0 {
            [0.0; 3]
        } else {
            [0, 1, 2].map(|d| velocity.iter().map(|v| v[d]).sum::<f64>() / n as f64)
        };
        let sides = Floor::sides(lower, upper);
        Self {
            time,
            mean_velocity,
            max_speed: velocity.iter().map(|&v| norm(v)).fold(0.0, f64::max),
            clusters,
            all_on_side: sides.map(|f| n > 0 && on_floor_count(position, radius, &labels, f) == n),
        }
    }

    /// The sample of [`landing_time`] for gravity along the unit vector `down`.
    pub fn sample(&self, down: [f64; 3]) -> CloudSample {
        CloudSample {
            time: self.time,
            settling_velocity: dot(self.mean_velocity, down),
            max_speed: self.max_speed,
            all_on_floor: self.all_on_side[Floor::side_index(down)],
        }
    }
}

/// One sample of a cloud for [`landing_time`]: time, settling velocity, the speed of the
/// fastest sphere and whether every sphere lies on the floor or on spheres that do.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CloudSample {
    pub time: f64,
    pub settling_velocity: f64,
    pub max_speed: f64,
    pub all_on_floor: bool,
}

/// The first time at which every sphere rests: all lie on the floor or on spheres that
/// do, and the fastest is slower than [`REST_SPEED_FRACTION`] of the largest settling
/// velocity reached up to then (so a cloud still at rest where it was released has not
/// landed). `None` if that never happens.
pub fn landing_time(samples: impl IntoIterator<Item = CloudSample>) -> Option<f64> {
    let mut peak = 0.0f64;
    for s in samples {
        peak = peak.max(s.settling_velocity);
        if peak > 0.0 && s.all_on_floor && s.max_speed < REST_SPEED_FRACTION * peak {
            return Some(s.time);
        }
    }
    None
}
