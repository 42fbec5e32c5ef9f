//! Collocation: the closest point of a surface to a point, and the weights that tie the point
//! to that face's nodes.

use super::geometry::{self, Face};
use super::search::Grid;
use super::{MortarError, Prepared, Surface, prepare};
use crate::artifact::mesh::{norm, sub};

/// Where a point projects on a surface.
#[derive(Debug, Clone, PartialEq)]
pub struct Projection {
    /// The face (its index in the surface's faces).
    pub face: usize,
    /// ξ* on the face's reference domain (clamped into it when the point lies beyond the
    /// surface's edge).
    pub xi: [f64; 2],
    /// x(ξ*).
    pub point: [f64; 3],
    /// The face's unit outward normal at ξ*.
    pub normal: [f64; 3],
    /// |p − x(ξ*)| (m).
    pub distance: f64,
    /// N_l(ξ*) by the face's nodes, in face order; they sum to 1.
    pub weights: Vec<(u32, f64)>,
}

/// A surface made ready for many projections: its faces on a search grid.
pub struct Projector<'a> {
    faces: Prepared<'a>,
    grid: Grid,
    search_distance: f64,
}

impl<'a> Projector<'a> {
    /// Faces farther than `search_distance` (m) from a point are not considered for it.
    pub fn new(
        coords: &[[f64; 3]],
        surface: &'a Surface,
        search_distance: f64,
    ) -> Result<Projector<'a>, MortarError> {
        if !(search_distance >= 0.0 && search_distance.is_finite()) {
            return Err(MortarError::Settings(format!(
                "the search distance must be a finite length ≥ 0, not {search_distance}"
            )));
        }
        let faces = prepare(coords, surface, search_distance)?;
        let grid = Grid::new(&faces.boxes);
        Ok(Projector {
            faces,
            grid,
            search_distance,
        })
    }

    /// The closest projection of `point` onto the surface within the search distance: the
    /// face of the smallest distance (the first such face on a tie).
    pub fn project(&self, point: [f64; 3]) -> Option<Projection> {
        let query = geometry::BoundingBox {
            low: point,
            high: point,
        };
        let mut candidates = Vec::new();
        self.grid.candidates(&query, &mut candidates);
        let mut best: Option<(f64, usize, [f64; 2], [f64; 3])> = None;
        for &f in &candidates {
            let f = f as usize;
            if !self.faces.boxes[f].contains(point) {
                continue;
            }
            let Some((distance, xi, at)) = self.onto(f, point) else {
                continue;
            };
            if !(distance <= self.search_distance) {
                continue;
            }
            if best.is_none_or(|(smallest, ..)| distance < smallest) {
                best = Some((distance, f, xi, at));
            }
        }
        let (distance, f, xi, at) = best?;
        Some(self.projection(f, xi, at, distance))
    }

    /// The closest projection of `point` onto the surface whatever its distance (the search
    /// distance ignored): every face, those whose boxes are nearest first, until no box is
    /// nearer than the best point found. `None` only if no face gives a closest point (its
    /// iteration fails). Slower than [`Projector::project`]: for the few points it leaves out,
    /// to say how far they are.
    pub fn nearest(&self, point: [f64; 3]) -> Option<Projection> {
        // A face lies in its box, so the distance to the box bounds the face's from below.
        let mut order: Vec<(f64, usize)> = self
            .faces
            .boxes
            .iter()
            .enumerate()
            .map(|(f, b)| {
                let outside: [f64; 3] = std::array::from_fn(|axis| {
                    (b.low[axis] - point[axis])
                        .max(point[axis] - b.high[axis])
                        .max(0.0)
                });
                (norm(outside), f)
            })
            .collect();
        order.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let mut best: Option<(f64, usize, [f64; 2], [f64; 3])> = None;
        for (bound, f) in order {
            if best.is_some_and(|(smallest, ..)| bound > smallest) {
                break;
            }
            let Some((distance, xi, at)) = self.onto(f, point) else {
                continue;
            };
            if best.is_none_or(|(smallest, best_f, ..)| {
                distance < smallest || (distance == smallest && f < best_f)
            }) {
                best = Some((distance, f, xi, at));
            }
        }
        let (distance, f, xi, at) = best?;
        Some(self.projection(f, xi, at, distance))
    }

    /// The closest point of face `f` to `point` (ξ clamped into the face): its distance, ξ*
    /// and x(ξ*); `None` if the iteration fails.
    fn onto(&self, f: usize, point: [f64; 3]) -> Option<(f64, [f64; 2], [f64; 3])> {
        let face: &Face = &self.faces.faces[f];
        let xi = geometry::closest_point(face, point)?;
        let xi = geometry::clamp_xi(face.kind, xi);
        let at = face.point(xi);
        Some((norm(sub(point, at)), xi, at))
    }

    fn projection(&self, f: usize, xi: [f64; 2], at: [f64; 3], distance: f64) -> Projection {
        let face = &self.faces.faces[f];
        let shapes = face.shapes(xi);
        Projection {
            face: f,
            xi,
            point: at,
            normal: face.unit_normal(xi).unwrap_or(self.faces.planes[f].normal),
            distance,
            weights: self.faces.nodes[f]
                .iter()
                .zip(&shapes.values)
                .map(|(&node, &value)| (node, value))
                .collect(),
        }
    }
}

/// The closest projection of `point` onto `surface` within `search_distance` (m); `None` if
/// there is none or the surface is invalid. Build a [`Projector`] to project many points.
pub fn project_point(
    coords: &[[f64; 3]],
    surface: &Surface,
    point: [f64; 3],
    search_distance: f64,
) -> Option<Projection> {
    Projector::new(coords, surface, search_distance)
        .ok()?
        .project(point)
}
