//! Structured hexahedral grids of a box domain and their level hierarchy.
//!
//! Level `L` of a box with `coarse = [nx, ny, nz]` cells has `coarse * 2^(L-1)` cells per
//! direction (the seed's "MG-Level" tables). Each level is a uniform tensor grid, so every
//! cell is the same axis-aligned box of size `h = (x1 - x0) / n` per direction.
//!
//! Unknowns (see [`crate`] for the element): one value per face for each velocity
//! component, one pressure per cell. Faces are grouped in three *families* by their normal
//! direction `a` (x-faces, y-faces, z-faces); a scalar face field is one `Vec<f64>` with the
//! x-, y- and z-families stored one after the other, each family in lexicographic order
//! (`i` fastest). Cells are lexicographic too: `c = i + nx (j + ny k)`.

use std::fmt;

/// Boundary condition on one side of the box.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BoundaryKind {
    /// Prescribed velocity (no-slip wall, moving lid, inflow profile): the face values of
    /// the velocity on this side are kept as given.
    Dirichlet,
    /// Do-nothing (natural) outflow: `nu du/dn - p n = -p_b n` with a given constant `p_b`.
    DoNothing,
    /// Periodic pair with the opposite side (both sides must say so).
    Periodic,
}

/// Boundary kinds of the six sides: `sides[d][0]` at `x_d = lower`, `sides[d][1]` at upper.
pub type Boundaries = [[BoundaryKind; 2]; 3];

/// Why a grid cannot be built; the field named is the offending input.
#[derive(Debug, Clone, PartialEq)]
pub enum GridError {
    /// `upper <= lower` in the direction given.
    EmptyBox { direction: usize },
    /// A coarse cell count of zero in the direction given.
    NoCells { direction: usize },
    /// Level 0 (levels start at 1).
    LevelZero,
    /// Only one side of a direction is periodic.
    HalfPeriodic { direction: usize },
}

impl fmt::Display for GridError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        const AXIS: [&str; 3] = ["x", "y", "z"];
        match self {
            GridError::EmptyBox { direction } => {
                write!(f, "box: upper <= lower in {}", AXIS[*direction])
            }
            GridError::NoCells { direction } => {
                write!(f, "coarse: zero cells in {}", AXIS[*direction])
            }
            GridError::LevelZero => write!(f, "level: must be >= 1"),
            GridError::HalfPeriodic { direction } => write!(
                f,
                "boundaries: only one side of {} is periodic",
                AXIS[*direction]
            ),
        }
    }
}

impl std::error::Error for GridError {}

/// One level of the grid hierarchy of a box domain.
#[derive(Debug, Clone, PartialEq)]
pub struct Grid {
    /// Lower corner `[x0, y0, z0]`.
    pub lower: [f64; 3],
    /// Upper corner `[x1, y1, z1]`.
    pub upper: [f64; 3],
    /// Cells per direction on level 1.
    pub coarse: [usize; 3],
    /// Level, 1 = coarse grid.
    pub level: u32,
    /// Boundary conditions of the six sides.
    pub bc: Boundaries,
}

impl Grid {
    /// Checks the input and builds level `level` of the box.
    pub fn new(
        lower: [f64; 3],
        upper: [f64; 3],
        coarse: [usize; 3],
        level: u32,
        bc: Boundaries,
    ) -> Result<Self, GridError> {
        if level == 0 {
            return Err(GridError::LevelZero);
        }
        for d in 0..3 {
            if upper[d].partial_cmp(&lower[d]) != Some(std::cmp::Ordering::Greater) {
                return Err(GridError::EmptyBox { direction: d });
            }
            if coarse[d] == 0 {
                return Err(GridError::NoCells { direction: d });
            }
            let per = bc[d].map(|k| k == BoundaryKind::Periodic);
            if per[0] != per[1] {
                return Err(GridError::HalfPeriodic { direction: d });
            }
        }
        Ok(Grid {
            lower,
            upper,
            coarse,
            level,
            bc,
        })
    }

    /// The next coarser level, `None` on level 1.
    pub fn coarser(&self) -> Option<Grid> {
        (self.level > 1).then(|| Grid {
            level: self.level - 1,
            ..self.clone()
        })
    }

    /// Cells per direction: `coarse * 2^(level-1)`.
    pub fn n(&self) -> [usize; 3] {
        self.coarse.map(|c| c << (self.level - 1))
    }

    /// Cell size per direction.
    pub fn h(&self) -> [f64; 3] {
        let n = self.n();
        [0, 1, 2].map(|d| (self.upper[d] - self.lower[d]) / n[d] as f64)
    }

    /// Cell volume `hx hy hz`.
    pub fn cell_volume(&self) -> f64 {
        let h = self.h();
        h[0] * h[1] * h[2]
    }

    /// Area of a face of family `a` (normal direction `a`).
    pub fn face_area(&self, a: usize) -> f64 {
        let h = self.h();
        h[(a + 1) % 3] * h[(a + 2) % 3]
    }

    /// Whether direction `d` is periodic.
    pub fn periodic(&self, d: usize) -> bool {
        self.bc[d][0] == BoundaryKind::Periodic
    }

    /// Number of cells (pressure unknowns).
    pub fn num_cells(&self) -> usize {
        self.n().iter().product()
    }

    /// Number of distinct faces (unknowns of one velocity component).
    pub fn num_faces(&self) -> usize {
        self.layout().off[3]
    }

    /// Degrees of freedom of the Q1~/Q0 pair: `3 x faces + cells` (three velocity
    /// components on every face, one pressure per cell).
    pub fn dofs(&self) -> usize {
        3 * self.num_faces() + self.num_cells()
    }

    /// Index arithmetic of this level.
    pub fn layout(&self) -> Layout {
        Layout::new(self.n(), [0, 1, 2].map(|d| self.periodic(d)))
    }

    /// Centre of cell `c = [i, j, k]`.
    pub fn cell_centre(&self, c: [usize; 3]) -> [f64; 3] {
        let h = self.h();
        [0, 1, 2].map(|d| self.lower[d] + (c[d] as f64 + 0.5) * h[d])
    }

    /// Centre of the face of family `a` with face coordinates `f`.
    pub fn face_centre(&self, a: usize, f: [usize; 3]) -> [f64; 3] {
        let h = self.h();
        [0, 1, 2].map(|d| {
            let off = if d == a { 0.0 } else { 0.5 };
            self.lower[d] + (f[d] as f64 + off) * h[d]
        })
    }

    /// Per-face flag of the faces whose velocity is prescribed by the box boundary
    /// conditions (faces on [`BoundaryKind::Dirichlet`] sides).
    pub fn dirichlet_mask(&self) -> Vec<bool> {
        let lay = self.layout();
        let mut mask = vec![false; lay.num_faces()];
        for a in 0..3 {
            if self.periodic(a) {
                continue;
            }
            for (side, m) in [0, lay.n[a]].into_iter().enumerate() {
                if self.bc[a][side] != BoundaryKind::Dirichlet {
                    continue;
                }
                lay.for_each_face_at(a, m, |idx| mask[idx] = true);
            }
        }
        mask
    }

    /// Adds to `mask` the faces of all cells with a non-zero marker (the fictitious-boundary
    /// hook: marker 0 outer, `p` boundary, `-p` inner cell of particle `p`). The velocity of
    /// these faces is then prescribed like a Dirichlet boundary.
    pub fn mark_faces(&self, markers: &[i32], mask: &mut [bool]) {
        let lay = self.layout();
        assert_eq!(markers.len(), lay.num_cells(), "markers: one per cell");
        for (c, &m) in markers.iter().enumerate() {
            if m == 0 {
                continue;
            }
            let cc = lay.cell_coords(c);
            for a in 0..3 {
                mask[lay.face(a, cc)] = true;
                mask[lay.face(a, lay.upper(a, cc))] = true;
            }
        }
    }

    /// Whether the pressure is only determined up to a constant (no do-nothing side).
    pub fn pressure_singular(&self) -> bool {
        self.bc
            .iter()
            .flatten()
            .all(|&k| k != BoundaryKind::DoNothing)
    }
}

/// Index arithmetic of one level: cells, face families, adjacency.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Layout {
    /// Cells per direction.
    pub n: [usize; 3],
    /// Periodic directions.
    pub periodic: [bool; 3],
    /// Extent of face family `a` per direction: `n[d]`, plus one along `a` unless periodic.
    pub fdim: [[usize; 3]; 3],
    /// Start of each family in a face field; `off[3]` is the number of faces.
    pub off: [usize; 4],
}

impl Layout {
    /// The layout of a grid of `n` cells with the periodic directions given.
    pub fn new(n: [usize; 3], periodic: [bool; 3]) -> Self {
        let fdim = [0, 1, 2].map(|a| {
            let mut d = n;
            if !periodic[a] {
                d[a] += 1;
            }
            d
        });
        let mut off = [0; 4];
        for a in 0..3 {
            off[a + 1] = off[a] + fdim[a].iter().product::<usize>();
        }
        Layout {
            n,
            periodic,
            fdim,
            off,
        }
    }

    /// Number of cells.
    pub fn num_cells(&self) -> usize {
        self.n.iter().product()
    }

    /// Number of faces.
    pub fn num_faces(&self) -> usize {
        self.off[3]
    }

    /// Index of cell `[i, j, k]`.
    #[inline]
    pub fn cell(&self, c: [usize; 3]) -> usize {
        c[0] + self.n[0] * (c[1] + self.n[1] * c[2])
    }

    /// Coordinates of cell index `c`.
    #[inline]
    pub fn cell_coords(&self, c: usize) -> [usize; 3] {
        let i = c % self.n[0];
        let r = c / self.n[0];
        [i, r % self.n[1], r / self.n[1]]
    }

    /// Index of the face of family `a` with face coordinates `f`.
    #[inline]
    pub fn face(&self, a: usize, f: [usize; 3]) -> usize {
        let d = &self.fdim[a];
        self.off[a] + f[0] + d[0] * (f[1] + d[1] * f[2])
    }

    /// Face coordinates of the face with index `idx` inside family `a` (index relative to
    /// the start of the family).
    #[inline]
    pub fn face_coords(&self, a: usize, idx: usize) -> [usize; 3] {
        let d = &self.fdim[a];
        let i = idx % d[0];
        let r = idx / d[0];
        [i, r % d[1], r / d[1]]
    }

    /// Family and face coordinates of the face with index `idx` in a face field.
    #[inline]
    pub fn face_of(&self, idx: usize) -> (usize, [usize; 3]) {
        let a = (0..3).rfind(|&a| self.off[a] <= idx).expect("face index");
        (a, self.face_coords(a, idx - self.off[a]))
    }

    /// Face coordinates of the upper face of family `a` of cell `c` (periodic wrap).
    #[inline]
    pub fn upper(&self, a: usize, c: [usize; 3]) -> [usize; 3] {
        let mut u = c;
        u[a] += 1;
        if self.periodic[a] && u[a] == self.n[a] {
            u[a] = 0;
        }
        u
    }

    /// The cells on either side of face `f` of family `a`: `[minus, plus]` (the face is the
    /// upper face of `minus` and the lower face of `plus`), `None` outside the box.
    #[inline]
    pub fn face_cells(&self, a: usize, f: [usize; 3]) -> [Option<[usize; 3]>; 2] {
        let minus = if f[a] > 0 {
            let mut c = f;
            c[a] -= 1;
            Some(c)
        } else if self.periodic[a] {
            let mut c = f;
            c[a] = self.n[a] - 1;
            Some(c)
        } else {
            None
        };
        let plus = (f[a] < self.n[a]).then_some(f);
        [minus, plus]
    }

    /// Calls `g` with the index of every face of family `a` whose coordinate along `a` is
    /// `m`.
    pub fn for_each_face_at(&self, a: usize, m: usize, mut g: impl FnMut(usize)) {
        let d = self.fdim[a];
        for k in 0..d[2] {
            for j in 0..d[1] {
                for i in 0..d[0] {
                    let f = [i, j, k];
                    if f[a] == m {
                        g(self.face(a, f));
                    }
                }
            }
        }
    }
}

/// DOF count of level `level` of a box with `coarse` cells and no periodic direction:
/// `3 x faces + cells`, faces = `(nx+1) ny nz + nx (ny+1) nz + nx ny (nz+1)`.
pub fn dofs_of_level(coarse: [usize; 3], level: u32) -> usize {
    let n = coarse.map(|c| c << (level - 1));
    let faces = (n[0] + 1) * n[1] * n[2] + n[0] * (n[1] + 1) * n[2] + n[0] * n[1] * (n[2] + 1);
    3 * faces + n[0] * n[1] * n[2]
}

#[cfg(test)]
mod tests {
    use super::*;
    use BoundaryKind::*;

    const WALLS: Boundaries = [[Dirichlet; 2]; 3];

    /// Seed, slides "A single sedimenting sphere" and "Drafting, kissing and tumbling":
    /// 5x5x25 coarse cells, levels 1-5 have 7,075 / 53,300 / 413,200 / 3,252,800 /
    /// 25,811,200 DOFs, with 2,150 / 16,100 / 124,400 / 977,600 / 7,750,400 faces.
    #[test]
    fn seed_dof_table_5x5x25() {
        let dofs = [7_075, 53_300, 413_200, 3_252_800, 25_811_200];
        let faces = [2_150, 16_100, 124_400, 977_600, 7_750_400];
        for level in 1..=5u32 {
            let g = Grid::new([0.0; 3], [2.0, 2.0, 10.0], [5, 5, 25], level, WALLS).unwrap();
            assert_eq!(g.dofs(), dofs[level as usize - 1], "level {level}");
            assert_eq!(g.num_faces(), faces[level as usize - 1], "level {level}");
            assert_eq!(dofs_of_level([5, 5, 25], level), g.dofs());
        }
    }

    /// Seed, slide "Drag coefficient": 12x12x36 coarse cells, 54,864 / 426,816 /
    /// 3,366,144 / 26,735,616 DOFs on levels 1-4.
    #[test]
    fn seed_dof_table_12x12x36() {
        let dofs = [54_864, 426_816, 3_366_144, 26_735_616];
        for (l, &want) in dofs.iter().enumerate() {
            assert_eq!(dofs_of_level([12, 12, 36], l as u32 + 1), want);
        }
    }

    /// A periodic direction identifies the two end faces: one face fewer per row.
    #[test]
    fn periodic_faces_are_shared() {
        let mut bc = WALLS;
        bc[2] = [Periodic; 2];
        let g = Grid::new([0.0; 3], [1.0; 3], [2, 2, 2], 1, bc).unwrap();
        assert_eq!(g.num_faces(), 3 * 2 * 4 + 8);
        let lay = g.layout();
        assert_eq!(lay.upper(2, [0, 0, 1]), [0, 0, 0]);
        assert_eq!(lay.face_cells(2, [1, 1, 0])[0], Some([1, 1, 1]));
    }

    /// A periodic direction one cell thick (a quasi-2D box): one face layer, which is
    /// both the lower and the upper face of every cell, with that cell on both sides.
    #[test]
    fn periodic_direction_of_one_cell() {
        let mut bc = WALLS;
        bc[2] = [Periodic; 2];
        let g = Grid::new([0.0; 3], [1.0, 1.0, 0.5], [2, 2, 1], 1, bc).unwrap();
        assert_eq!(g.num_faces(), 3 * 2 + 2 * 3 + 4);
        let lay = g.layout();
        assert_eq!(lay.upper(2, [1, 0, 0]), [1, 0, 0]);
        assert_eq!(lay.face_cells(2, [1, 0, 0]), [Some([1, 0, 0]); 2]);
        assert_eq!(g.h()[2], 0.5);
    }

    #[test]
    fn bad_input_names_the_field() {
        let e = Grid::new([0.0; 3], [1.0, 0.0, 1.0], [1, 1, 1], 1, WALLS).unwrap_err();
        assert_eq!(e, GridError::EmptyBox { direction: 1 });
        assert!(e.to_string().contains("in y"));
        let mut bc = WALLS;
        bc[0][1] = Periodic;
        assert_eq!(
            Grid::new([0.0; 3], [1.0; 3], [2, 2, 2], 1, bc).unwrap_err(),
            GridError::HalfPeriodic { direction: 0 }
        );
        assert_eq!(
            Grid::new([0.0; 3], [1.0; 3], [2, 0, 2], 1, WALLS).unwrap_err(),
            GridError::NoCells { direction: 1 }
        );
        assert_eq!(
            Grid::new([0.0; 3], [1.0; 3], [2, 2, 2], 0, WALLS).unwrap_err(),
            GridError::LevelZero
        );
    }

    #[test]
    fn marker_faces_become_dirichlet() {
        let bc = [[Periodic; 2]; 3];
        let g = Grid::new([0.0; 3], [1.0; 3], [4, 4, 4], 1, bc).unwrap();
        let mut mask = g.dirichlet_mask();
        assert!(mask.iter().all(|&m| !m));
        let mut markers = vec![0; g.num_cells()];
        markers[g.layout().cell([1, 2, 3])] = -1;
        markers[g.layout().cell([2, 2, 3])] = 1;
        g.mark_faces(&markers, &mut mask);
        // two adjacent cells: 12 faces, one shared
        assert_eq!(mask.iter().filter(|&&m| m).count(), 11);
    }
}
