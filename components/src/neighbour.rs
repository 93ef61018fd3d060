use bevy_ecs::prelude::Resource;

use crate::Columns;

/// Verlet-list settings: the skin added to the contact distance, the reach within which
/// pairs must always be listed, and the particle re-sorting policy.
#[derive(Resource, Debug, Clone, Copy)]
pub struct NeighbourSettings {
    pub skin: f64,
    /// Pairs with a surface gap below `reach` (< `skin`) are always listed: the list is
    /// rebuilt when a particle may have moved `(skin - reach) / 2`, not `skin / 2`. Zero
    /// for contacts only; the lubrication range when the coupling's lubrication acts.
    pub reach: f64,
    /// Re-sort particles in cell order at every `sort_every`-th rebuild (0: never).
    pub sort_every: u32,
}

/// Half Verlet neighbour list: every pair within `r_i + r_j + skin` once, in the row of
/// its lower row index. The pairs of row `i` are `k` in `start[i]..start[i+1]`, with
/// partner `neighbours[k]` (> i) and owner `owner[k]` (= i), in cell order. The reverse
/// index lists, for each particle, the pairs in which it is the partner:
/// `rev_pairs[rev_start[p]..rev_start[p+1]]`, ascending, with their owners beside them in
/// `rev_owner` (the same as `owner[rev_pairs[..]]`, kept to spare the hot loop a lookup). With it, every particle sums the
/// forces of all its pairs itself, in a fixed order, while each pair force is computed once.
///
/// Narrowed rows (a two-level Verlet list): between rebuilds, each row can be ordered with
/// its pairs within `r_i + r_j + inner_skin` first, up to `near_end[i]`, and the reverse
/// index then lists those near pairs only. Until some particle has moved `inner_skin / 2`
/// no pair beyond `near_end` can touch, so the per-particle pair pass and the partner
/// pass read the near pairs only (the pair-ordered pass of sparse chunks reads whole
/// chunks, where a far pair just adds zero).
/// Without narrowing, `near_end[i] = start[i + 1]`. Rows are narrowed only in scenes
/// without a contact store ([`ContactHistory`]); with one, the store keeps its own compact
/// list of the near pairs instead (narrowing in place would move a pair's history).
#[derive(Resource, Debug, Clone, Default)]
pub struct VerletList {
    pub start: Vec<u32>,
    pub neighbours: Vec<u32>,
    pub owner: Vec<u32>,
    pub near_end: Vec<u32>,
    /// The inner skin of the last narrowing (the full `skin`: rows not narrowed).
    pub inner_skin: f64,
    /// Upper bound of any particle's displacement since the last narrowing, and the steps
    /// since.
    pub inner_bound: f64,
    pub inner_steps: u32,
    pub narrowings: u64,
    pub rev_start: Vec<u32>,
    pub rev_pairs: Vec<u32>,
    pub rev_owner: Vec<u32>,
    /// Positions at the last rebuild.
    pub reference: Columns,
    /// Set by systems that change the particle set (insertion) to force a rebuild.
    pub stale: bool,
    pub builds: u64,
    pub sorts: u64,
    /// Upper bound of any particle's displacement since the last rebuild, from the
    /// integrators' [`StepMotion`]; the exact check runs only when it exceeds skin/2.
    pub motion_bound: f64,
}

/// Bound of the change of any position coordinate since the neighbour list last looked,
/// max |dx_d| over particles and d, summed over the moves the integrators report (the
/// corrector's move of one step and the predictor's of the next; sqrt(3) times it bounds
/// every displacement). `None` when no integrator has reported since: the list then
/// assumes any motion.
#[derive(Resource, Debug, Clone, Copy, Default)]
pub struct StepMotion {
    pub max_component: Option<f64>,
}

impl StepMotion {
    /// An integrator moved every coordinate by at most `largest`.
    pub fn add(&mut self, largest: f64) {
        self.max_component = Some(self.max_component.unwrap_or(0.0) + largest);
    }
}

impl VerletList {
    /// Number of listed pairs.
    pub fn pairs(&self) -> usize {
        self.neighbours.len()
    }

    /// All near partners of particle `i` (all partners when the rows are not narrowed):
    /// its own row, then the owners of the pairs it is partner in.
    pub fn partners(&self, i: usize) -> impl Iterator<Item = u32> + '_ {
        let fwd = &self.neighbours[self.start[i] as usize..self.near_end[i] as usize];
        let rev = &self.rev_owner[self.rev_start[i] as usize..self.rev_start[i + 1] as usize];
        fwd.iter().copied().chain(rev.iter().copied())
    }
}

/// A permutation of the particle rows applied this step (`new row k = old row perm[k]`),
/// published by the neighbour-list system for every other per-particle block.
#[derive(Resource, Debug, Clone, Default)]
pub struct Reorder {
    pub perm: Option<Vec<u32>>,
}

/// Candidate wall contacts in compressed rows, rebuilt with the Verlet list: the walls
/// within `r_i + skin` of particle `i` are `walls[start[i]..start[i+1]]` (indices into
/// `Walls::list`), and `particle[e]` is the particle of entry `e` (so that a pass over
/// the entries need not walk the rows, most of them empty). Walls are static, so the
/// Verlet criterion covers them too.
#[derive(Resource, Debug, Clone, Default)]
pub struct WallList {
    pub start: Vec<u32>,
    pub walls: Vec<u16>,
    pub particle: Vec<u32>,
    /// `VerletList::builds` when this list was built.
    pub built_for: u64,
}

/// The contact store: per-pair history (the tangential spring of a friction model, the
/// contact state of an adhesion model), `width` values per pair, for the pairs of its own
/// compact list `pairs`: the pairs of the Verlet list within `r_i + r_j + inner_skin`
/// (a two-level list, as the narrowed rows of [`VerletList`]) and every pair that holds
/// history, selected again at each rebuild and narrowing. Until some particle has moved
/// half the inner skin, no other listed pair can touch, so the contact kernel reads these
/// pairs only. Values are in blocks of four pairs (the lanes of the contact kernel):
/// value `c` of pair `k` is `values[index(k, c)]`, and the four pairs of a block have each
/// value in four consecutive slots. Pairs are keyed by the particles' stable ids, so at
/// every selection, rebuild and re-sort the history of a pair that is still listed moves
/// to its new place; a pair that left the list loses it. Values are kept for the pair
/// oriented from the particle that owns the pair's row to its partner: when a rebuild
/// gives the row to the other particle, the directed values (`directed`) are negated as
/// they move, so the contact kernel never needs the ids.
/// Present only when a model needs it.
#[derive(Resource, Debug, Clone, Default)]
pub struct ContactHistory {
    pub width: usize,
    /// Offset of the one directed 3-vector of a pair's values (the tangential spring),
    /// if any.
    pub directed: Option<usize>,
    pub values: Vec<f64>,
    pub pairs: PairList,
}

/// A half list of pairs in compressed rows, as [`VerletList`] without narrowing: the pairs
/// of row `i` are `k` in `start[i]..start[i+1]`, partner `neighbours[k]` (> i, ascending)
/// and owner `owner[k]` (= i). `ids` are the stable ids of the rows when the list was
/// made; `scatter` says where the contact kernel adds each pair's force and torques.
#[derive(Debug, Clone, Default)]
pub struct PairList {
    pub ids: Vec<u32>,
    pub start: Vec<u32>,
    pub neighbours: Vec<u32>,
    pub owner: Vec<u32>,
    pub scatter: ScatterPlan,
}

/// Where the contact kernel sums the pairs of a [`PairList`]: the pairs are split into
/// work items of `pairs_per_item` consecutive pairs (a whole number of blocks of four);
/// each item adds the force and torque of each of its pairs to both particles' records in
/// an accumulator of its own, one record per particle it touches (its slots); each
/// particle then sums its records over the items, in item order. So every pair force is
/// computed once, nothing is written per pair, and every particle's sum has a fixed order
/// (items, then pairs within an item), whatever the number of threads.
///
/// The slots of item `g` are `item_start[g]..item_start[g+1]`, with particle
/// `particle[s]` at slot `s`, ascending within the item. Pair `k` of item `g` adds to its
/// owner at slot `item_start[g] + pair_slot[k][0]` and to its partner at
/// `item_start[g] + pair_slot[k][1]`. Particle `p` has its records at the slots
/// `gather[gather_start[p]..gather_start[p+1]]`, ascending.
#[derive(Debug, Clone, Default)]
pub struct ScatterPlan {
    pub pairs_per_item: usize,
    pub item_start: Vec<u32>,
    pub particle: Vec<u32>,
    pub pair_slot: Vec<[u16; 2]>,
    pub gather_start: Vec<u32>,
    pub gather: Vec<u32>,
}

impl PairList {
    /// Number of pairs.
    pub fn pairs(&self) -> usize {
        self.neighbours.len()
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        let s = &self.scatter;
        4 * (self.ids.capacity()
            + self.start.capacity()
            + self.neighbours.capacity()
            + self.owner.capacity()
            + s.item_start.capacity()
            + s.particle.capacity()
            + s.pair_slot.capacity()
            + s.gather_start.capacity()
            + s.gather.capacity())
    }
}

impl ScatterPlan {
    /// Number of slots (records of all items).
    pub fn slots(&self) -> usize {
        self.particle.len()
    }
}

impl ContactHistory {
    /// Pairs per block.
    pub const LANES: usize = 4;

    /// Slot of value `component` of pair `pair`.
    #[inline(always)]
    pub fn index(&self, pair: usize, component: usize) -> usize {
        ((pair / Self::LANES) * self.width + component) * Self::LANES + pair % Self::LANES
    }

    /// Length of `values` for `pairs` listed pairs (whole blocks).
    pub fn len_for(&self, pairs: usize) -> usize {
        pairs.div_ceil(Self::LANES) * Self::LANES * self.width
    }
}
