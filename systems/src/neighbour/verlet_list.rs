//! Contact detection: cell index method (Quentrec & Brot 1973) and Verlet neighbour lists
//! (Verlet 1967), as on the seed's "Contact detection" slide.
//!
//! The list is rebuilt when the largest displacement since the last build exceeds half
//! the skin: then no pair can have closed the gap `r_i + r_j + skin` unseen (half of
//! `skin - reach` with a [`NeighbourSettings::reach`]: no pair can have come within
//! `r_i + r_j + reach` unseen). At rebuilds
//! the particles are re-sorted in cell order (counting sort on the cell index), so that
//! neighbours are close in memory.
use bevy_ecs::prelude::*;
use grainflow_components::{
    Clumps, ContactHistory, NeighbourSettings, PairList, Particles, PerParticle, Reorder,
    ScatterPlan, Sinks, StepMotion, VerletList,
};
use rayon::prelude::*;

use crate::neighbour::compressed_rows::{join_rows, reverse_index};
use crate::team::StaticSplit;
use crate::{row_chunks, CHUNK};

/// Rebuild the Verlet list when needed, re-sorting particles in cell order.
#[allow(clippy::too_many_arguments)]
pub fn verlet_list(
    mut particles: ResMut<Particles>,
    mut list: ResMut<VerletList>,
    settings: Res<NeighbourSettings>,
    mut reorder: ResMut<Reorder>,
    history: Option<ResMut<ContactHistory>>,
    mut motion: ResMut<StepMotion>,
    sinks: Option<ResMut<Sinks>>,
    clumps: Option<Res<Clumps>>,
) {
    let _span = tracing::info_span!("verlet_list").entered();
    reorder.perm = None;
    let n = particles.len();
    // pairs closer than the reach stay listed while no particle has moved (skin - reach)/2
    let half_skin = 0.5 * (settings.skin - settings.reach);
    // The integrator's bound on this step's motion spares the exact check (a pass over
    // all positions) until the bound itself reaches that.
    let step_motion = motion
        .max_component
        .take()
        .map_or(f64::INFINITY, |m| 3f64.sqrt() * m);
    list.motion_bound += step_motion;
    let mut stale = list.stale || list.reference[0].len() != n;
    if !stale && list.motion_bound > half_skin {
        let exact = max_displacement_squared(&particles, &list).sqrt();
        stale = exact > half_skin;
        list.motion_bound = exact;
    }
    if stale {
        let leaving = sinks.map(|mut s| std::mem::take(&mut s.leaving));
        rebuild(
            &mut particles,
            &mut list,
            &settings,
            &mut reorder,
            leaving.as_deref().unwrap_or(&[]),
            clumps.as_deref().map(|c| &c.body_of_id[..]),
        );
    }
    let inner = narrowing_due(&mut list, settings.skin, step_motion, stale);
    match (history, inner) {
        // With a contact store, the store selects its own pairs (the rows stay whole).
        (Some(mut history), Some(inner)) => {
            select_history_pairs(&particles, &mut list, &mut history, inner)
        }
        (Some(_), None) | (None, None) => {}
        (None, Some(inner)) if inner < settings.skin => narrow_rows(&particles, &mut list, inner),
        (None, Some(_)) => {
            if list.inner_skin < settings.skin {
                let _span = tracing::info_span!("widen_rows").entered();
                whole_rows(&mut list, settings.skin);
            }
        }
    }
}

/// Aimed-for number of steps between two narrowings of the rows: the inner skin is set to
/// the distance the particles are expected to cover in that many steps (twice their mean
/// bound per step since the last narrowing), so a narrowing, which costs about one pass
/// over the list, is paid for by that many cheaper contact passes.
const STEPS_PER_NARROWING: f64 = 50.0;

/// The inner skin to narrow the rows to now (see [`VerletList::near_end`]; `skin`: whole
/// rows), if a narrowing is due: after a rebuild, when some particle may have moved half
/// the inner skin since the last narrowing, or when whole rows (after the first build,
/// when no motion was known yet, or after fast motion) could now be narrowed to half the
/// skin or less. The rows are whole again when the particles move too fast for an inner
/// skin below `skin` to last.
fn narrowing_due(list: &mut VerletList, skin: f64, step_motion: f64, rebuilt: bool) -> Option<f64> {
    list.inner_bound += step_motion;
    list.inner_steps += 1;
    let per_step = list.inner_bound / list.inner_steps as f64;
    let inner = (2.0 * STEPS_PER_NARROWING * per_step).max(skin / 32.0);
    let worth_narrowing = list.inner_skin >= skin && inner <= 0.5 * skin;
    if !rebuilt && !worth_narrowing && list.inner_bound <= 0.5 * list.inner_skin {
        return None;
    }
    list.inner_bound = 0.0;
    list.inner_steps = 0;
    Some(inner.min(skin))
}

/// Order every row with its pairs within `r_i + r_j + inner_skin` first, in list order (a
/// stable partition), set `near_end`, and index the near pairs by partner.
fn narrow_rows(particles: &Particles, list: &mut VerletList, inner_skin: f64) {
    let _span = tracing::info_span!("narrow_rows").entered();
    let n = particles.len();
    let [x, y, z] = &particles.position;
    let r = &particles.radius;
    let VerletList {
        start,
        neighbours,
        near_end,
        ..
    } = list;
    near_end.resize(n, 0);
    (
        row_chunks(neighbours, start, n, 1),
        near_end.par_chunks_mut(CHUNK).collect::<Vec<_>>(),
    )
        .into_par_iter()
        .enumerate()
        .static_for_each(|(c, (nbrs, ends))| {
            let base = c * CHUNK;
            let pair_base = start[base] as usize;
            let mut far = Vec::new();
            for (k, end) in ends.iter_mut().enumerate() {
                let i = base + k;
                let row = start[i] as usize - pair_base..start[i + 1] as usize - pair_base;
                let row = &mut nbrs[row];
                let (xi, yi, zi, ri) = (x[i], y[i], z[i], r[i] + inner_skin);
                far.clear();
                let mut near = 0;
                for q in 0..row.len() {
                    let j = row[q] as usize;
                    let (dx, dy, dz) = (xi - x[j], yi - y[j], zi - z[j]);
                    let reach = ri + r[j];
                    if dx * dx + dy * dy + dz * dz < reach * reach {
                        row[near] = j as u32;
                        near += 1;
                    } else {
                        far.push(j as u32);
                    }
                }
                row[near..].copy_from_slice(&far);
                *end = start[i] + near as u32;
            }
        });
    list.inner_skin = inner_skin;
    list.narrowings += 1;
    index_near_pairs(list);
}

/// Every pair of each row near (rows not narrowed), with its reverse index.
fn whole_rows(list: &mut VerletList, skin: f64) {
    list.near_end.clear();
    list.near_end.extend_from_slice(&list.start[1..]);
    list.inner_skin = skin;
    index_near_pairs(list);
}

/// The reverse index of the near pairs (all pairs when the rows are not narrowed): by
/// partner, ascending pair index within each partner.
fn index_near_pairs(list: &mut VerletList) {
    let n = list.near_end.len();
    let VerletList {
        start,
        near_end,
        neighbours,
        owner,
        ..
    } = &*list;
    let (rev_start, rev_pairs) = if near_end[..] == start[1..] {
        // Whole rows: all pairs, one range (loose benchmark state, 578 indexes: 0.18 ms
        // per index on average, against 0.56 ms with a range per row; 2026-12-02).
        reverse_index(n, neighbours, std::iter::once(0..neighbours.len()))
    } else {
        let near = (0..n).map(|i| start[i] as usize..near_end[i] as usize);
        reverse_index(n, neighbours, near)
    };
    list.rev_owner = rev_pairs.par_iter().map(|&k| owner[k as usize]).collect();
    list.rev_start = rev_start;
    list.rev_pairs = rev_pairs;
}

/// Rebuild the list from the cell index, re-sorting the particles in cell order at every
/// `sort_every`-th rebuild. The rows in `leaving` (ascending; particles past a sink) are
/// dropped first; the published row map then takes the other blocks from the old rows to
/// the kept, possibly re-sorted, ones.
fn rebuild(
    particles: &mut Particles,
    list: &mut VerletList,
    settings: &NeighbourSettings,
    reorder: &mut Reorder,
    leaving: &[u32],
    body_of_id: Option<&[u32]>,
) {
    let _span = tracing::info_span!("verlet_rebuild").entered();
    let keep = (!leaving.is_empty()).then(|| kept_rows(particles.len(), leaving));
    if let Some(keep) = &keep {
        particles.permute_rows(keep);
    }
    let n = particles.len();
    let sort = settings.sort_every > 0 && list.builds.is_multiple_of(settings.sort_every as u64);
    let cell_sort = tracing::info_span!("cell_sort").entered();
    let grid = CellGrid::new(particles, settings.skin);
    let mut cell_of = grid.cell_indices(particles);
    let order = grid.counting_sort(&cell_of);
    let members = if sort && n > 0 {
        particles.permute_rows(&order.members);
        cell_of = order.members.iter().map(|&k| cell_of[k as usize]).collect();
        reorder.perm = Some(match &keep {
            Some(keep) => order.members.iter().map(|&k| keep[k as usize]).collect(),
            None => order.members,
        });
        list.sorts += 1;
        None
    } else {
        reorder.perm = keep;
        Some(order.members)
    };
    drop(cell_sort);
    build_half_list(
        particles,
        &grid,
        &cell_of,
        &order.cell_start,
        members.as_deref(),
        settings.skin,
        body_of_id,
        list,
    );
    for (reference, position) in list.reference.iter_mut().zip(&particles.position) {
        reference.resize(n, 0.0);
        (reference.par_chunks_mut(CHUNK), position.par_chunks(CHUNK))
            .into_par_iter()
            .static_for_each(|(to, from)| to.copy_from_slice(from));
    }
    list.stale = false;
    list.builds += 1;
    list.motion_bound = 0.0;
}

/// The rows of `0..n` not in `leaving` (ascending), in order.
fn kept_rows(n: usize, leaving: &[u32]) -> Vec<u32> {
    let mut out = Vec::with_capacity(n - leaving.len());
    let mut next = leaving.iter().copied().peekable();
    for i in 0..n as u32 {
        if next.peek() == Some(&i) {
            next.next();
        } else {
            out.push(i);
        }
    }
    out
}

/// Largest squared displacement of any particle since the last rebuild.
pub fn max_displacement_squared(particles: &Particles, list: &VerletList) -> f64 {
    let [x, y, z] = &particles.position;
    let [rx, ry, rz] = &list.reference;
    (
        x.par_chunks(CHUNK),
        y.par_chunks(CHUNK),
        z.par_chunks(CHUNK),
        rx.par_chunks(CHUNK),
        ry.par_chunks(CHUNK),
        rz.par_chunks(CHUNK),
    )
        .into_par_iter()
        .static_map_reduce(
            |(x, y, z, rx, ry, rz)| {
                let mut m = 0.0f64;
                for k in 0..x.len() {
                    let (dx, dy, dz) = (x[k] - rx[k], y[k] - ry[k], z[k] - rz[k]);
                    m = m.max(dx * dx + dy * dy + dz * dz);
                }
                m
            },
            || 0.0,
            f64::max,
        )
}

/// Uniform cell grid over the particles' bounding box, cell edge >= 2 r_max + skin, so
/// that every pair within `r_i + r_j + skin` lies in the same or an adjacent cell.
///
/// Cells are numbered tile by tile: tiles of `TILE`^3 cells in x-y-z order, and the cells
/// of a tile in x-y-z order, so that the cells around a cell, and after the re-sort the
/// particles in them, are close in memory in all three directions, not only in x (with
/// plain x-y-z numbering a neighbour in z is a whole layer of cells away).
pub struct CellGrid {
    pub origin: [f64; 3],
    pub edge: f64,
    pub dims: [usize; 3],
    /// Tiles per direction, `dims` rounded up to whole tiles.
    pub tiles: [usize; 3],
    pub max_radius: f64,
}

/// Cells per tile edge.
const TILE: usize = 4;

/// The particles' bounding box (lowest and highest coordinate per axis) and largest
/// radius, in one pass over the rows (minima and maxima: the same for any thread count).
fn bounds(particles: &Particles) -> ([f64; 3], [f64; 3], f64) {
    type Bounds = ([f64; 3], [f64; 3], f64);
    let none: Bounds = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3], 0.0);
    let [x, y, z] = &particles.position;
    (
        x.par_chunks(CHUNK),
        y.par_chunks(CHUNK),
        z.par_chunks(CHUNK),
        particles.radius.par_chunks(CHUNK),
    )
        .into_par_iter()
        .static_map_reduce(
            |(x, y, z, r)| {
                // A fold per column keeps each extreme in a register: updating array
                // elements value by value took 267 against 34 us per rebuild (loose
                // state, one thread, 2026-12-02).
                let cols = [x, y, z];
                (
                    cols.map(|c| c.iter().copied().fold(f64::INFINITY, f64::min)),
                    cols.map(|c| c.iter().copied().fold(f64::NEG_INFINITY, f64::max)),
                    r.iter().copied().fold(0.0, f64::max),
                )
            },
            || none,
            |(lo_a, hi_a, r_a), (lo_b, hi_b, r_b)| {
                (
                    [0, 1, 2].map(|d| lo_a[d].min(lo_b[d])),
                    [0, 1, 2].map(|d| hi_a[d].max(hi_b[d])),
                    r_a.max(r_b),
                )
            },
        )
}

/// Particles ordered by cell: those of cell `c` are `members[cell_start[c]..cell_start[c+1]]`.
pub struct CellOrder {
    pub cell_start: Vec<u32>,
    pub members: Vec<u32>,
}

impl CellGrid {
    pub fn new(particles: &Particles, skin: f64) -> Self {
        let n = particles.len();
        let (lo, hi, max_radius) = bounds(particles);
        if n == 0 {
            return Self {
                origin: [0.0; 3],
                edge: 1.0,
                dims: [1, 1, 1],
                tiles: [1, 1, 1],
                max_radius,
            };
        }
        let mut edge = 2.0 * max_radius + skin;
        let span = [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]];
        // Keep the cell count near the particle count in sparse scenes (an inflow spread
        // over a tall hopper): larger cells, same correctness.
        let cells = |e: f64| (0..3).map(|d| (span[d] / e).floor() + 1.0).product::<f64>();
        let budget = 2.0 * n as f64 + 64.0;
        if cells(edge) > budget {
            edge *= (cells(edge) / budget).cbrt();
            while cells(edge) > budget {
                edge *= 1.05;
            }
        }
        let dims = [0, 1, 2].map(|d| (span[d] / edge).floor() as usize + 1);
        Self {
            origin: lo,
            edge,
            dims,
            tiles: dims.map(|d| d.div_ceil(TILE)),
            max_radius,
        }
    }

    /// Number of cell indices (the cells of whole tiles).
    pub fn n_cells(&self) -> usize {
        self.tiles.iter().product::<usize>() * TILE * TILE * TILE
    }

    /// Index of the cell at cell coordinates `c`.
    #[inline(always)]
    pub fn cell(&self, c: [usize; 3]) -> usize {
        let tile = (c[2] / TILE * self.tiles[1] + c[1] / TILE) * self.tiles[0] + c[0] / TILE;
        tile * TILE * TILE * TILE + ((c[2] % TILE) * TILE + c[1] % TILE) * TILE + c[0] % TILE
    }

    /// The cells `cx - 1 ..= cx + 1` of a row of cells (clipped to the grid), as at most two
    /// runs (first x, number of cells) of consecutive cell indices: a run breaks only
    /// where the row crosses into the next tile. An unused run has length 0.
    #[inline(always)]
    pub fn x_runs(&self, cx: usize) -> [(usize, usize); 2] {
        let lo = cx.saturating_sub(1);
        let hi = (cx + 2).min(self.dims[0]);
        // The first x of the next tile after `lo`, if the row reaches it.
        let split = (lo / TILE + 1) * TILE;
        if split < hi {
            [(lo, split - lo), (split, hi - split)]
        } else {
            [(lo, hi - lo), (hi, 0)]
        }
    }

    /// Cell coordinates of cell index `c`.
    #[inline(always)]
    pub fn coords(&self, c: u32) -> [usize; 3] {
        let c = c as usize;
        let (tile, local) = (c / (TILE * TILE * TILE), c % (TILE * TILE * TILE));
        let t = [
            tile % self.tiles[0],
            (tile / self.tiles[0]) % self.tiles[1],
            tile / (self.tiles[0] * self.tiles[1]),
        ];
        [
            t[0] * TILE + local % TILE,
            t[1] * TILE + (local / TILE) % TILE,
            t[2] * TILE + local / (TILE * TILE),
        ]
    }

    /// Cell index of every particle.
    pub fn cell_indices(&self, particles: &Particles) -> Vec<u32> {
        let [x, y, z] = &particles.position;
        let inv = 1.0 / self.edge;
        let (o, dims) = (self.origin, self.dims);
        let mut cell = vec![0u32; particles.len()];
        cell.par_chunks_mut(CHUNK).enumerate().for_each(|(c, out)| {
            let base = c * CHUNK;
            for (k, slot) in out.iter_mut().enumerate() {
                let i = base + k;
                let ix = (((x[i] - o[0]) * inv) as usize).min(dims[0] - 1);
                let iy = (((y[i] - o[1]) * inv) as usize).min(dims[1] - 1);
                let iz = (((z[i] - o[2]) * inv) as usize).min(dims[2] - 1);
                *slot = self.cell([ix, iy, iz]) as u32;
            }
        });
        cell
    }

    /// Stable counting sort of particle rows by cell.
    pub fn counting_sort(&self, cell_of: &[u32]) -> CellOrder {
        let mut cell_start = vec![0u32; self.n_cells() + 1];
        for &c in cell_of {
            cell_start[c as usize + 1] += 1;
        }
        for c in 0..self.n_cells() {
            cell_start[c + 1] += cell_start[c];
        }
        let mut fill = cell_start.clone();
        let mut members = vec![0u32; cell_of.len()];
        for (i, &c) in cell_of.iter().enumerate() {
            members[fill[c as usize] as usize] = i as u32;
            fill[c as usize] += 1;
        }
        CellOrder {
            cell_start,
            members,
        }
    }
}

/// The non-empty member ranges (`cell_start` of the first and past the last cell) of the
/// runs of cells around one cell: at most 9 rows of cells in y and z, each at most two
/// runs of consecutive cell indices ([`CellGrid::x_runs`]).
#[derive(Default)]
struct Stencil {
    cell: Option<u32>,
    ranges: [(usize, usize); 18],
    len: usize,
}

impl Stencil {
    /// With `rows_in_cell_order`, the runs of cells all before `cell` are left out: their
    /// rows all come before the rows of `cell`, so they hold no partner of a higher row.
    fn fill(&mut self, grid: &CellGrid, cell: u32, cell_start: &[u32], rows_in_cell_order: bool) {
        let [cx, cy, cz] = grid.coords(cell);
        let dims = grid.dims;
        let runs = grid.x_runs(cx);
        self.len = 0;
        for gz in cz.saturating_sub(1)..(cz + 2).min(dims[2]) {
            for gy in cy.saturating_sub(1)..(cy + 2).min(dims[1]) {
                for &(gx, len) in runs.iter().filter(|r| r.1 > 0) {
                    let c = grid.cell([gx, gy, gz]);
                    if rows_in_cell_order && c + len <= cell as usize {
                        continue;
                    }
                    let (m0, m1) = (cell_start[c] as usize, cell_start[c + len] as usize);
                    if m0 < m1 {
                        self.ranges[self.len] = (m0, m1);
                        self.len += 1;
                    }
                }
            }
        }
        self.cell = Some(cell);
    }

    fn ranges(&self) -> &[(usize, usize)] {
        &self.ranges[..self.len]
    }
}

/// Build the half list: for each particle, the others of higher row index within
/// `r_i + r_j + skin`, scanned over the 27 surrounding cells in cell order; then the owner
/// of every pair and the reverse index (a counting sort of the pairs by partner).
/// `members` lists the rows of each cell (`cell_start` order); `None` when the rows are
/// themselves in cell order (just re-sorted): a cell's members are then a range of rows,
/// the runs of cells all before the particle's cell are not read at all
/// ([`Stencil::fill`]), and the others are scanned from past row `i`. With clumps
/// (`body_of_id`: the body of every particle id, `u32::MAX` for a free sphere), two
/// members of one body are no pair.
#[allow(clippy::too_many_arguments)]
fn build_half_list(
    particles: &Particles,
    grid: &CellGrid,
    cell_of: &[u32],
    cell_start: &[u32],
    members: Option<&[u32]>,
    skin: f64,
    body_of_id: Option<&[u32]>,
    list: &mut VerletList,
) {
    let n = particles.len();
    let id = &particles.id;
    let [x, y, z] = &particles.position;
    let r = &particles.radius;
    let scan = tracing::info_span!("pair_scan").entered();
    let rows: Vec<(Vec<u32>, Vec<u32>)> = (0..n.div_ceil(CHUNK))
        .into_par_iter()
        .map(|chunk| {
            let range = chunk * CHUNK..((chunk + 1) * CHUNK).min(n);
            let mut nbrs = Vec::with_capacity(range.len() * 6);
            let mut counts = Vec::with_capacity(range.len());
            // The member ranges around the cell of the last row, kept while the rows
            // stay in that cell (all its rows, when the rows are in cell order).
            let mut stencil = Stencil::default();
            for i in range {
                let before = nbrs.len();
                if stencil.cell != Some(cell_of[i]) {
                    stencil.fill(grid, cell_of[i], cell_start, members.is_none());
                }
                let (xi, yi, zi, ri) = (x[i], y[i], z[i], r[i] + skin);
                let within = |(xj, yj, zj, rj): (f64, f64, f64, f64)| {
                    let (dx, dy, dz) = (xi - xj, yi - yj, zi - zj);
                    let cut = ri + rj;
                    dx * dx + dy * dy + dz * dz < cut * cut
                };
                for &(m0, m1) in stencil.ranges() {
                    match members {
                        // Rows in cell order: the members are the rows m0..m1, read as
                        // slices (no index checks), from past row i.
                        None => {
                            let lo = m0.max(i + 1);
                            if lo < m1 {
                                let near = x[lo..m1].iter().zip(&y[lo..m1]);
                                let near = near.zip(&z[lo..m1]).zip(&r[lo..m1]);
                                for (k, (((&xj, &yj), &zj), &rj)) in near.enumerate() {
                                    if within((xj, yj, zj, rj)) {
                                        nbrs.push((lo + k) as u32);
                                    }
                                }
                            }
                        }
                        Some(m) => {
                            let later = m[m0..m1].iter().map(|&j| j as usize).filter(|&j| j > i);
                            for j in later {
                                if within((x[j], y[j], z[j], r[j])) {
                                    nbrs.push(j as u32);
                                }
                            }
                        }
                    }
                }
                if let Some(body) = body_of_id {
                    let of = |row: usize| body.get(id[row] as usize).copied().unwrap_or(u32::MAX);
                    let own = of(i);
                    if own != u32::MAX {
                        let mut kept = before;
                        for k in before..nbrs.len() {
                            if of(nbrs[k] as usize) != own {
                                nbrs[kept] = nbrs[k];
                                kept += 1;
                            }
                        }
                        nbrs.truncate(kept);
                    }
                }
                // Partners in ascending row order: pair order follows memory order.
                nbrs[before..].sort_unstable();
                counts.push((nbrs.len() - before) as u32);
            }
            (nbrs, counts)
        })
        .collect();
    drop(scan);
    let _span = tracing::info_span!("list_index").entered();
    let chunks: Vec<_> = rows
        .iter()
        .map(|(nbrs, counts)| (&nbrs[..], &counts[..]))
        .collect();
    (list.start, list.owner, list.neighbours) = join_rows(&chunks);
    whole_rows(list, skin);
}

/// Select the pairs of the contact store (see [`ContactHistory`]): the listed pairs within
/// `r_i + r_j + inner_skin` and every listed pair that holds history, each with its
/// history carried from the store's previous pairs; then their scatter plan. While the
/// rows hold the same particles as at the last selection, a row's previous pairs are
/// found by a merge with its listed pairs (both ascending); after a re-sort or an
/// insertion, by the stable ids of both particles ([`carry_history`]).
fn select_history_pairs(
    particles: &Particles,
    list: &mut VerletList,
    history: &mut ContactHistory,
    inner_skin: f64,
) {
    let _span = tracing::info_span!("select_history_pairs").entered();
    let n = particles.len();
    let w = history.width;
    let same_rows = history.pairs.ids == particles.id;
    // The history to carry: the store's own values (same rows) or the values moved to
    // the places of `list` (rows changed).
    let carried = (!same_rows).then(|| carry_history(history, &particles.id, list));
    let source = carried.as_deref().unwrap_or(&history.values);
    let old = &history.pairs;
    let [x, y, z] = &particles.position;
    let r = &particles.radius;
    // Per chunk of rows: the kept partners, the row lengths, and the place of each kept
    // pair's history in `source` (u32::MAX: none).
    let rows: Vec<(Vec<u32>, Vec<u32>, Vec<u32>)> = (0..n.div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| {
            let (mut nbrs, mut counts, mut from) = (Vec::new(), Vec::new(), Vec::new());
            for i in c * CHUNK..((c + 1) * CHUNK).min(n) {
                let (xi, yi, zi, ri) = (x[i], y[i], z[i], r[i] + inner_skin);
                let before = nbrs.len();
                let mut q = if same_rows { old.start[i] as usize } else { 0 };
                for k in list.start[i] as usize..list.start[i + 1] as usize {
                    let j = list.neighbours[k];
                    let place = if same_rows {
                        let end = old.start[i + 1] as usize;
                        while q < end && old.neighbours[q] < j {
                            q += 1;
                        }
                        (q < end && old.neighbours[q] == j).then_some(q)
                    } else {
                        Some(k)
                    };
                    let held =
                        place.filter(|&s| (0..w).any(|v| source[history.index(s, v)] != 0.0));
                    let (dx, dy, dz) = (xi - x[j as usize], yi - y[j as usize], zi - z[j as usize]);
                    let reach = ri + r[j as usize];
                    if held.is_some() || dx * dx + dy * dy + dz * dz < reach * reach {
                        nbrs.push(j);
                        from.push(held.map_or(u32::MAX, |s| s as u32));
                    }
                }
                counts.push((nbrs.len() - before) as u32);
            }
            (nbrs, counts, from)
        })
        .collect();
    let chunks: Vec<_> = rows
        .iter()
        .map(|(nbrs, counts, _)| (&nbrs[..], &counts[..]))
        .collect();
    let (start, owner, neighbours) = join_rows(&chunks);
    let from: Vec<u32> = rows
        .iter()
        .flat_map(|(_, _, f)| f.iter().copied())
        .collect();
    let total = neighbours.len();
    let mut values = vec![0.0; history.len_for(total)];
    values
        .par_chunks_mut(CHUNK * w.max(1))
        .enumerate()
        .for_each(|(c, out)| {
            for q in c * CHUNK..((c + 1) * CHUNK).min(total) {
                if from[q] != u32::MAX {
                    for v in 0..w {
                        out[history.index(q, v) - c * CHUNK * w] =
                            source[history.index(from[q] as usize, v)];
                    }
                }
            }
        });
    let scatter = scatter_plan(n, &owner, &neighbours, CHUNK);
    let pairs = PairList {
        ids: particles.id.clone(),
        start,
        neighbours,
        owner,
        scatter,
    };
    history.pairs = pairs;
    history.values = values;
    list.inner_skin = inner_skin;
    list.narrowings += 1;
}

/// The [`ScatterPlan`] of pairs `(owner[k], neighbours[k])` among `n` particles, in work
/// items of `pairs_per_item` pairs: each item's slots are the distinct particles of its
/// pairs, ascending; the records of each particle are indexed by a counting sort.
pub fn scatter_plan(
    n: usize,
    owner: &[u32],
    neighbours: &[u32],
    pairs_per_item: usize,
) -> ScatterPlan {
    let _span = tracing::info_span!("scatter_plan").entered();
    assert!(
        pairs_per_item.is_multiple_of(ContactHistory::LANES) && 2 * pairs_per_item <= 1 << 16,
        "an item is whole blocks with 16-bit slots"
    );
    // Per item: its distinct particles (marked in `slot_of`, one array per worker, reset
    // after each item), sorted, so that the particles' sums read each item's records in
    // order; then each pair's two slots.
    let items: Vec<(Vec<u32>, Vec<[u16; 2]>)> = owner
        .par_chunks(pairs_per_item)
        .zip(neighbours.par_chunks(pairs_per_item))
        .map_init(
            || vec![u32::MAX; n],
            |slot_of, (own, nbrs)| {
                let mut touched: Vec<u32> = Vec::new();
                for &p in own.iter().chain(nbrs) {
                    if slot_of[p as usize] == u32::MAX {
                        slot_of[p as usize] = 0;
                        touched.push(p);
                    }
                }
                touched.sort_unstable();
                for (s, &p) in touched.iter().enumerate() {
                    slot_of[p as usize] = s as u32;
                }
                let slots = (own.iter().zip(nbrs))
                    .map(|(&i, &j)| [slot_of[i as usize] as u16, slot_of[j as usize] as u16])
                    .collect();
                for &p in &touched {
                    slot_of[p as usize] = u32::MAX;
                }
                (touched, slots)
            },
        )
        .collect();
    let mut item_start = Vec::with_capacity(items.len() + 1);
    item_start.push(0u32);
    for (touched, _) in &items {
        item_start.push(item_start[item_start.len() - 1] + touched.len() as u32);
    }
    let mut particle = Vec::with_capacity(item_start[items.len()] as usize);
    let mut pair_slot = Vec::with_capacity(owner.len());
    for (touched, slots) in &items {
        particle.extend_from_slice(touched);
        pair_slot.extend_from_slice(slots);
    }
    let (gather_start, gather) = reverse_index(n, &particle, std::iter::once(0..particle.len()));
    ScatterPlan {
        pairs_per_item,
        item_start,
        particle,
        pair_slot,
        gather_start,
        gather,
    }
}

/// The history of the store's pairs moved to the pairs of `list` (in blocks of four, as
/// [`ContactHistory::values`]), matched by the ids of both particles (in the store's
/// list the pair sat in the row of its lower row index); the directed values are negated
/// when the pair's row owner changed; other pairs get zero.
fn carry_history(history: &ContactHistory, ids: &[u32], list: &VerletList) -> Vec<f64> {
    let _span = tracing::info_span!("carry_history").entered();
    let w = history.width;
    let pairs = list.neighbours.len();
    let mut values = vec![0.0; history.len_for(pairs)];
    let old = &history.pairs;
    if w == 0 || old.pairs() == 0 {
        return values;
    }
    let max_id = ids
        .iter()
        .chain(&old.ids)
        .copied()
        .max()
        .map_or(0, |m| m as usize + 1);
    let mut old_row = vec![u32::MAX; max_id];
    for (row, &id) in old.ids.iter().enumerate() {
        old_row[id as usize] = row as u32;
    }
    // CHUNK pairs per work item: a whole number of blocks.
    values
        .par_chunks_mut(CHUNK * w)
        .enumerate()
        .for_each(|(c, out)| {
            for k in c * CHUNK..((c + 1) * CHUNK).min(pairs) {
                let (a, b) = (
                    old_row[ids[list.owner[k] as usize] as usize],
                    old_row[ids[list.neighbours[k] as usize] as usize],
                );
                let (lo, hi) = (a.min(b) as usize, a.max(b));
                if b == u32::MAX || a == u32::MAX || old.start.len() <= lo + 1 {
                    continue;
                }
                let row = old.start[lo] as usize..old.start[lo + 1] as usize;
                if let Ok(pos) = old.neighbours[row.clone()].binary_search(&hi) {
                    let src = row.start + pos;
                    // the old owner (row lo) owns the new row too, or the partner does
                    let turned = a as usize != lo;
                    for v in 0..w {
                        let value = history.values[history.index(src, v)];
                        let directed = history.directed.is_some_and(|o| (o..o + 3).contains(&v));
                        out[history.index(k, v) - c * CHUNK * w] =
                            if turned && directed { -value } else { value };
                    }
                }
            }
        });
    values
}

#[cfg(test)]
mod tests {
    use super::*;
    use grainflow_components::NewParticle;

    /// The one-pass bounds equal a serial fold over the columns, on one thread and on
    /// three (the parts' minima and maxima combine exactly).
    #[test]
    fn bounds_equal_a_serial_fold_for_any_thread_count() {
        let mut state = 7u64;
        let mut uniform = || crate::inflow::next_f64(&mut state);
        let mut particles = Particles::default();
        for id in 0..10_000 {
            particles.push(NewParticle {
                id,
                material: 0,
                radius: 0.01 + 0.02 * uniform(),
                density: 1000.0,
                position: [2.0 * uniform() - 1.0, 3.0 * uniform(), uniform() - 5.0],
                velocity: [0.0; 3],
                angular_velocity: [0.0; 3],
            });
        }
        let lo = particles
            .position
            .each_ref()
            .map(|c| c.iter().copied().fold(f64::INFINITY, f64::min));
        let hi = particles
            .position
            .each_ref()
            .map(|c| c.iter().copied().fold(f64::NEG_INFINITY, f64::max));
        let r = particles.radius.iter().copied().fold(0.0, f64::max);
        for threads in [1, 3] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            assert_eq!(
                pool.install(|| bounds(&particles)),
                (lo, hi, r),
                "{threads} threads"
            );
        }
    }
}
