//! Candidate pairs by bucketing: the master faces' bounding boxes on a uniform grid of cells
//! about as large as a face, so that a query touches a few cells whatever the surface's size.

use super::geometry::BoundingBox;

/// The faces overlapping each cell, stored by cell in one array (`start[c]..start[c + 1]`).
pub(super) struct Grid {
    origin: [f64; 3],
    cell: f64,
    dims: [usize; 3],
    start: Vec<usize>,
    faces: Vec<u32>,
}

impl Grid {
    pub fn new(boxes: &[BoundingBox]) -> Grid {
        let mut low = [f64::INFINITY; 3];
        let mut high = [f64::NEG_INFINITY; 3];
        let mut extent_sum = 0.0;
        for b in boxes {
            for axis in 0..3 {
                low[axis] = low[axis].min(b.low[axis]);
                high[axis] = high[axis].max(b.high[axis]);
            }
            extent_sum += (0..3).map(|a| b.high[a] - b.low[a]).fold(0.0, f64::max);
        }
        let span = (0..3).map(|a| high[a] - low[a]).fold(0.0, f64::max);
        // A cell of the mean face size, no smaller than needed to keep the cells a few per face.
        let mut cell = (extent_sum / boxes.len().max(1) as f64).max(1e-9 * span);
        if !(cell > 0.0) || !cell.is_finite() {
            cell = 1.0;
        }
        let dims_of = |cell: f64| -> [usize; 3] {
            std::array::from_fn(|a| (((high[a] - low[a]) / cell) as usize + 1).max(1))
        };
        let mut dims = dims_of(cell);
        while dims.iter().product::<usize>() > 8 * boxes.len() + 1024 {
            cell *= 2.0;
            dims = dims_of(cell);
        }
        let mut grid = Grid {
            origin: if low[0].is_finite() { low } else { [0.0; 3] },
            cell,
            dims,
            start: Vec::new(),
            faces: Vec::new(),
        };
        let n_cells = dims.iter().product::<usize>();
        let mut count = vec![0usize; n_cells + 1];
        for b in boxes {
            grid.for_each_cell(b, |c| count[c + 1] += 1);
        }
        for c in 0..n_cells {
            count[c + 1] += count[c];
        }
        let mut fill = count.clone();
        let mut faces = vec![0u32; count[n_cells]];
        for (face, b) in boxes.iter().enumerate() {
            grid.for_each_cell(b, |c| {
                faces[fill[c]] = face as u32;
                fill[c] += 1;
            });
        }
        grid.start = count;
        grid.faces = faces;
        grid
    }

    fn cell_range(&self, b: &BoundingBox) -> [(usize, usize); 3] {
        std::array::from_fn(|a| {
            let index = |x: f64| -> usize {
                // `as usize` saturates (and maps NaN to 0): no index leaves the grid.
                (((x - self.origin[a]) / self.cell).floor().max(0.0) as usize).min(self.dims[a] - 1)
            };
            (index(b.low[a]), index(b.high[a]))
        })
    }

    fn for_each_cell(&self, b: &BoundingBox, mut at: impl FnMut(usize)) {
        let [(i0, i1), (j0, j1), (k0, k1)] = self.cell_range(b);
        for k in k0..=k1 {
            for j in j0..=j1 {
                for i in i0..=i1 {
                    at((k * self.dims[1] + j) * self.dims[0] + i);
                }
            }
        }
    }

    /// The faces whose cells meet the box `b`, sorted, each once (a superset of the faces whose
    /// boxes overlap `b`).
    pub fn candidates(&self, b: &BoundingBox, out: &mut Vec<u32>) {
        out.clear();
        self.for_each_cell(b, |c| {
            out.extend_from_slice(&self.faces[self.start[c]..self.start[c + 1]])
        });
        out.sort_unstable();
        out.dedup();
    }
}
