//! Faces as maps of their reference domain, the auxiliary plane of a slave face, projections
//! onto a face (along a direction and to the closest point) and convex clipping in the plane.

use crate::artifact::mesh::{cross, dot, norm, sub};
use crate::element::topology::FaceKind;
use crate::faces::face_shapes_into;

/// The most nodes a face has (quad8).
pub(super) const MAX_NODES: usize = 8;

/// A face and its nodes' coordinates, copied so that the inner loops touch one cache line or two.
#[derive(Debug, Clone, Copy)]
pub(super) struct Face {
    pub kind: FaceKind,
    pub x: [[f64; 3]; MAX_NODES],
}

/// Shape functions and their derivatives at one point, in the first `kind.n_nodes()` slots.
pub(super) struct Shapes {
    pub values: [f64; MAX_NODES],
    pub derivatives: [[f64; 2]; MAX_NODES],
}

/// Reference coordinates of the square's corners and mid-edge nodes, in face order.
const SQUARE_NODES: [[f64; 2]; 8] = [
    [-1.0, -1.0],
    [1.0, -1.0],
    [1.0, 1.0],
    [-1.0, 1.0],
    [0.0, -1.0],
    [1.0, 0.0],
    [0.0, 1.0],
    [-1.0, 0.0],
];
const TRIANGLE_NODES: [[f64; 2]; 6] = [
    [0.0, 0.0],
    [1.0, 0.0],
    [0.0, 1.0],
    [0.5, 0.0],
    [0.5, 0.5],
    [0.0, 0.5],
];

fn is_triangle(kind: FaceKind) -> bool {
    kind.n_corners() == 3
}

/// Reference coordinates of node `a` of a face of `kind`.
pub(super) fn node_xi(kind: FaceKind, a: usize) -> [f64; 2] {
    if is_triangle(kind) {
        TRIANGLE_NODES[a]
    } else {
        SQUARE_NODES[a]
    }
}

/// The reference point of the face's centre.
pub(super) fn centre_xi(kind: FaceKind) -> [f64; 2] {
    if is_triangle(kind) {
        [1.0 / 3.0; 2]
    } else {
        [0.0; 2]
    }
}

/// The nearest point of the reference domain (a clamp; exact for the square).
pub(super) fn clamp_xi(kind: FaceKind, [u, v]: [f64; 2]) -> [f64; 2] {
    if is_triangle(kind) {
        let (u, v) = (u.max(0.0), v.max(0.0));
        let excess = u + v - 1.0;
        if excess > 0.0 {
            // Back onto the hypotenuse along its normal, then into its span.
            let (u, v) = (u - 0.5 * excess, v - 0.5 * excess);
            [u.clamp(0.0, 1.0), v.clamp(0.0, 1.0)]
        } else {
            [u, v]
        }
    } else {
        [u.clamp(-1.0, 1.0), v.clamp(-1.0, 1.0)]
    }
}

/// How far `xi` lies outside the reference domain (0 inside), in reference units.
pub(super) fn outside_by(kind: FaceKind, [u, v]: [f64; 2]) -> f64 {
    if is_triangle(kind) {
        (-u).max(-v).max(u + v - 1.0).max(0.0)
    } else {
        (u.abs() - 1.0).max(v.abs() - 1.0).max(0.0)
    }
}

impl Face {
    pub fn new(kind: FaceKind, coords: &[[f64; 3]], nodes: &[u32]) -> Face {
        let mut x = [[0.0; 3]; MAX_NODES];
        for (slot, &node) in x.iter_mut().zip(nodes) {
            *slot = coords[node as usize];
        }
        Face { kind, x }
    }

    pub fn n_nodes(&self) -> usize {
        self.kind.n_nodes()
    }

    pub fn corners(&self) -> &[[f64; 3]] {
        &self.x[..self.kind.n_corners()]
    }

    #[inline]
    pub fn shapes_into(&self, xi: [f64; 2], shapes: &mut Shapes) {
        face_shapes_into(self.kind, xi, &mut shapes.values, &mut shapes.derivatives);
    }

    #[inline]
    pub fn shapes(&self, xi: [f64; 2]) -> Shapes {
        let mut shapes = Shapes {
            values: [0.0; MAX_NODES],
            derivatives: [[0.0; 2]; MAX_NODES],
        };
        face_shapes_into(self.kind, xi, &mut shapes.values, &mut shapes.derivatives);
        shapes
    }

    /// x(ξ) and its tangents x_u, x_v.
    #[inline]
    pub fn point_and_tangents(&self, shapes: &Shapes) -> ([f64; 3], [f64; 3], [f64; 3]) {
        let (mut x, mut x_u, mut x_v) = ([0.0; 3], [0.0; 3], [0.0; 3]);
        for a in 0..self.n_nodes() {
            let (value, [du, dv]) = (shapes.values[a], shapes.derivatives[a]);
            for axis in 0..3 {
                x[axis] += value * self.x[a][axis];
                x_u[axis] += du * self.x[a][axis];
                x_v[axis] += dv * self.x[a][axis];
            }
        }
        (x, x_u, x_v)
    }

    pub fn point(&self, xi: [f64; 2]) -> [f64; 3] {
        self.point_and_tangents(&self.shapes(xi)).0
    }

    /// The unit normal x_u × x_v / |x_u × x_v| at `xi` (outward by the face's orientation), or
    /// `None` where the map is singular.
    pub fn unit_normal(&self, xi: [f64; 2]) -> Option<[f64; 3]> {
        let (_, x_u, x_v) = self.point_and_tangents(&self.shapes(xi));
        let normal = cross(x_u, x_v);
        let length = norm(normal);
        // Relative to the tangents' size, so that the test does not depend on units.
        (length > 1e-12 * norm(x_u) * norm(x_v)).then(|| normal.map(|c| c / length))
    }

    /// The largest distance between two of its corners, a length scale.
    pub fn diameter(&self) -> f64 {
        let corners = self.corners();
        let mut largest: f64 = 0.0;
        for a in 0..corners.len() {
            for b in a + 1..corners.len() {
                largest = largest.max(norm(sub(corners[a], corners[b])));
            }
        }
        largest
    }

    /// The corners' bounding box, widened by `margin` and, for quadratic faces, by the distance
    /// of the mid-edge nodes from the box (a curved face may bulge past its nodes a little).
    pub fn bounding_box(&self, margin: f64) -> BoundingBox {
        let mut low = [f64::INFINITY; 3];
        let mut high = [f64::NEG_INFINITY; 3];
        for x in &self.x[..self.n_nodes()] {
            for axis in 0..3 {
                low[axis] = low[axis].min(x[axis]);
                high[axis] = high[axis].max(x[axis]);
            }
        }
        BoundingBox {
            low: low.map(|c| c - margin),
            high: high.map(|c| c + margin),
        }
    }
}

#[derive(Debug, Clone, Copy)]
pub(super) struct BoundingBox {
    pub low: [f64; 3],
    pub high: [f64; 3],
}

impl BoundingBox {
    pub fn overlaps(&self, other: &BoundingBox) -> bool {
        (0..3).all(|axis| self.low[axis] <= other.high[axis] && other.low[axis] <= self.high[axis])
    }

    pub fn contains(&self, x: [f64; 3]) -> bool {
        (0..3).all(|axis| self.low[axis] <= x[axis] && x[axis] <= self.high[axis])
    }
}

/// The auxiliary plane of a slave face: through its centre x₀, normal n₀ (the face's unit
/// normal there), with tangents t₁, t₂ such that (t₁, t₂, n₀) is right-handed.
#[derive(Debug, Clone, Copy)]
pub(super) struct Plane {
    pub origin: [f64; 3],
    pub normal: [f64; 3],
    pub t1: [f64; 3],
    pub t2: [f64; 3],
}

impl Plane {
    /// `None` if the face is singular at its centre.
    pub fn of(face: &Face) -> Option<Plane> {
        let centre = centre_xi(face.kind);
        let normal = face.unit_normal(centre)?;
        let origin = face.point(centre);
        // t₁ along the first side, made normal to n₀.
        let side = sub(face.x[1], face.x[0]);
        let along = sub(side, normal.map(|c| c * dot(side, normal)));
        let length = norm(along);
        if !(length > 0.0) {
            return None;
        }
        let t1 = along.map(|c| c / length);
        let t2 = cross(normal, t1);
        Some(Plane {
            origin,
            normal,
            t1,
            t2,
        })
    }

    /// In-plane coordinates of the projection of `x` along n₀.
    pub fn coordinates(&self, x: [f64; 3]) -> [f64; 2] {
        let d = sub(x, self.origin);
        [dot(d, self.t1), dot(d, self.t2)]
    }

    /// The corners of a face projected into the plane, in the face's order.
    pub fn polygon(&self, face: &Face) -> Vec<[f64; 2]> {
        face.corners()
            .iter()
            .map(|&x| self.coordinates(x))
            .collect()
    }
}

/// The first guess of [`project_along`] for one face and one plane: the face's map linearised
/// at its centre, ξ ≈ ξ_c + J_c⁻¹ (q − q_c), exact where the map is affine.
#[derive(Debug, Clone, Copy)]
pub(super) struct Guess {
    xi: [f64; 2],
    at: [f64; 2],
    inverse: [[f64; 2]; 2],
}

impl Guess {
    /// `None` if the face is seen edge-on from the plane at its centre.
    pub fn new(face: &Face, plane: &Plane) -> Option<Guess> {
        let xi = centre_xi(face.kind);
        let (x, x_u, x_v) = face.point_and_tangents(&face.shapes(xi));
        let J = [
            [dot(plane.t1, x_u), dot(plane.t1, x_v)],
            [dot(plane.t2, x_u), dot(plane.t2, x_v)],
        ];
        let columns = [solve_2x2(J, [1.0, 0.0])?, solve_2x2(J, [0.0, 1.0])?];
        Some(Guess {
            xi,
            at: plane.coordinates(x),
            inverse: [
                [columns[0][0], columns[1][0]],
                [columns[0][1], columns[1][1]],
            ],
        })
    }

    fn at(&self, target: [f64; 2]) -> [f64; 2] {
        let d = [target[0] - self.at[0], target[1] - self.at[1]];
        [
            self.xi[0] + self.inverse[0][0] * d[0] + self.inverse[0][1] * d[1],
            self.xi[1] + self.inverse[1][0] * d[0] + self.inverse[1][1] * d[1],
        ]
    }
}

/// The shape functions at the point ξ of `face` whose projection along the plane's normal is
/// `target` (in-plane coordinates): Newton on F(ξ) = (t₁·(x(ξ) − x₀),
/// t₂·(x(ξ) − x₀)) − target from the linearised guess, which is exact where the face is affine
/// in ξ (flat triangles, parallelograms). `None` if Newton meets a singular Jacobian, leaves
/// the neighbourhood of the face or does not converge.
pub(super) fn project_along(
    face: &Face,
    plane: &Plane,
    guess: &Guess,
    target: [f64; 2],
) -> Option<[f64; MAX_NODES]> {
    let mut xi = guess.at(target);
    let mut shapes = Shapes {
        values: [0.0; MAX_NODES],
        derivatives: [[0.0; 2]; MAX_NODES],
    };
    let mut previous = f64::NAN;
    for _ in 0..30 {
        face.shapes_into(xi, &mut shapes);
        let (x, x_u, x_v) = face.point_and_tangents(&shapes);
        let at = plane.coordinates(x);
        let residual = [at[0] - target[0], at[1] - target[1]];
        let jacobian = [
            [dot(plane.t1, x_u), dot(plane.t1, x_v)],
            [dot(plane.t2, x_u), dot(plane.t2, x_v)],
        ];
        let step = solve_2x2(jacobian, residual)?;
        let size = step[0].abs().max(step[1].abs());
        // A step of round-off: the shapes at hand are those of the answer.
        if size < 1e-14 {
            return Some(shapes.values);
        }
        xi = [xi[0] - step[0], xi[1] - step[1]];
        if !(outside_by(face.kind, xi) < 10.0) {
            return None;
        }
        // The error after a Newton step is about C × step², with C from the last two steps
        // (taken as 1 after the first).
        let contraction = if previous.is_nan() {
            1.0
        } else {
            size / (previous * previous)
        };
        if size < 1e-6 && contraction * size * size < 1e-16 {
            face.shapes_into(xi, &mut shapes);
            return Some(shapes.values);
        }
        previous = size;
    }
    None
}

/// The closest point of `face` to `x`: Gauss–Newton on ½ |x(ξ) − x|², from the face's centre.
/// Converges in one step on flat faces of affine maps, linearly (at a rate of the distance
/// times the curvature) on curved ones. `None` if it does not converge.
pub(super) fn closest_point(face: &Face, x: [f64; 3]) -> Option<[f64; 2]> {
    let mut xi = centre_xi(face.kind);
    for _ in 0..100 {
        let shapes = face.shapes(xi);
        let (at, x_u, x_v) = face.point_and_tangents(&shapes);
        let d = sub(at, x);
        let normal_matrix = [
            [dot(x_u, x_u), dot(x_u, x_v)],
            [dot(x_v, x_u), dot(x_v, x_v)],
        ];
        let step = solve_2x2(normal_matrix, [dot(x_u, d), dot(x_v, d)])?;
        xi = [xi[0] - step[0], xi[1] - step[1]];
        if !(outside_by(face.kind, xi) < 10.0) {
            return None;
        }
        if step[0].abs().max(step[1].abs()) < 1e-13 {
            return Some(xi);
        }
    }
    None
}

/// `A⁻¹ b`, or `None` if A is singular (relative to its entries) or not finite.
fn solve_2x2(A: [[f64; 2]; 2], b: [f64; 2]) -> Option<[f64; 2]> {
    let det = A[0][0] * A[1][1] - A[0][1] * A[1][0];
    let scale = (A[0][0].abs() + A[0][1].abs()) * (A[1][0].abs() + A[1][1].abs());
    if !(det.abs() > 1e-14 * scale) {
        return None;
    }
    Some([
        (A[1][1] * b[0] - A[0][1] * b[1]) / det,
        (A[0][0] * b[1] - A[1][0] * b[0]) / det,
    ])
}

/// Twice the signed area of (a, b, c): positive when counter-clockwise.
fn orient(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

/// Signed area (shoelace): positive for a counter-clockwise polygon.
pub(super) fn signed_area(polygon: &[[f64; 2]]) -> f64 {
    let mut twice = 0.0;
    for (idx, a) in polygon.iter().enumerate() {
        let b = polygon[(idx + 1) % polygon.len()];
        twice += a[0] * b[1] - a[1] * b[0];
    }
    0.5 * twice
}

/// The part of `subject` inside the convex counter-clockwise polygon `clip`
/// (Sutherland–Hodgman: the subject is cut by each of the clip's edges in turn), with
/// vertices closer than `tolerance` to the previous one dropped.
pub(super) fn clip(subject: &[[f64; 2]], clip: &[[f64; 2]], tolerance: f64) -> Vec<[f64; 2]> {
    let mut polygon = subject.to_vec();
    let mut next = Vec::with_capacity(subject.len() + clip.len());
    for (idx, &a) in clip.iter().enumerate() {
        let b = clip[(idx + 1) % clip.len()];
        next.clear();
        for (k, &p) in polygon.iter().enumerate() {
            let q = polygon[(k + 1) % polygon.len()];
            let (side_p, side_q) = (orient(a, b, p), orient(a, b, q));
            if side_p >= 0.0 {
                next.push(p);
            }
            if (side_p >= 0.0) != (side_q >= 0.0) {
                let t = side_p / (side_p - side_q);
                next.push([p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])]);
            }
        }
        std::mem::swap(&mut polygon, &mut next);
        if polygon.is_empty() {
            return polygon;
        }
    }
    // Clipping along shared edges leaves repeated vertices: drop them, so that coincident
    // polygons triangulate alike.
    let mut cleaned: Vec<[f64; 2]> = Vec::with_capacity(polygon.len());
    for p in polygon {
        let repeated = cleaned.last().is_some_and(|last: &[f64; 2]| {
            (p[0] - last[0]).abs().max((p[1] - last[1]).abs()) <= tolerance
        });
        if !repeated {
            cleaned.push(p);
        }
    }
    while cleaned.len() > 1 {
        let (first, last) = (cleaned[0], cleaned[cleaned.len() - 1]);
        if (first[0] - last[0]).abs().max((first[1] - last[1]).abs()) <= tolerance {
            cleaned.pop();
        } else {
            break;
        }
    }
    cleaned
}

/// Integration points of a convex counter-clockwise polygon: the triangles from its vertices'
/// centroid to each edge, the degree-5 rule on each. Calls `at(point, weight)`.
pub(super) fn for_each_point(polygon: &[[f64; 2]], mut at: impl FnMut([f64; 2], f64)) {
    let n = polygon.len() as f64;
    let centre = [
        polygon.iter().map(|p| p[0]).sum::<f64>() / n,
        polygon.iter().map(|p| p[1]).sum::<f64>() / n,
    ];
    for (idx, &a) in polygon.iter().enumerate() {
        let b = polygon[(idx + 1) % polygon.len()];
        let (ea, eb) = (
            [a[0] - centre[0], a[1] - centre[1]],
            [b[0] - centre[0], b[1] - centre[1]],
        );
        // Twice the triangle's area, the Jacobian of the map from the reference triangle.
        let jacobian = ea[0] * eb[1] - ea[1] * eb[0];
        if !(jacobian > 0.0) {
            continue;
        }
        for &([r, s], weight) in crate::element::quadrature::TRIANGLE_DEGREE_5.iter() {
            at(
                [
                    centre[0] + r * ea[0] + s * eb[0],
                    centre[1] + r * ea[1] + s * eb[1],
                ],
                weight * jacobian,
            );
        }
    }
}
