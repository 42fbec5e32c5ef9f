//! Assembly rate of every element kind: elements per second of `assemble` (element matrices
//! and the sparse sum) on a block of about 100,000 DOFs meshed with each kind, on one and on
//! two threads, best of three; and the element matrices alone (two threads). Run with `cargo bench -p squeal-stages --bench assembly`.

use squeal_stages::artifact::{ElementKind, Mesh};
use squeal_stages::assemble::with_default_materials;
use squeal_stages::fem::element::element_matrices;
use squeal_stages::mesh::{convert, structured};

/// A 0.4 × 0.1 × 0.05 m block of `cells` hexahedral cells as elements of `kind`.
fn block_of(kind: ElementKind, cells: [usize; 3]) -> Mesh {
    convert::as_kind(&structured::block([0.4, 0.1, 0.05], cells, "disc"), kind)
}

fn main() {
    println!(
        "{:<8} {:>9} {:>9} {:>12} {:>12} {:>8} {:>14}",
        "kind", "elements", "DOFs", "1 thread /s", "2 threads /s", "speed-up", "matrices /s"
    );
    for (kind, cells) in [
        (ElementKind::Hex8, [64, 16, 32]),
        (ElementKind::Hex20, [32, 8, 16]),
        (ElementKind::Tet4, [64, 16, 32]),
        (ElementKind::Tet10, [32, 8, 16]),
        (ElementKind::Wedge6, [64, 16, 32]),
        (ElementKind::Wedge15, [32, 8, 16]),
    ] {
        let mesh = block_of(kind, cells);
        let rate = |threads: usize| -> f64 {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("thread pool");
            let best = (0..3)
                .map(|_| {
                    let started = std::time::Instant::now();
                    pool.install(|| with_default_materials(&mesh, "", &[]).expect("assembly"));
                    started.elapsed().as_secs_f64()
                })
                .fold(f64::INFINITY, f64::min);
            mesh.elements.len() as f64 / best
        };
        let (one, two) = (rate(1), rate(2));
        // The element matrices alone, on two threads: the part of assembly that is per element.
        let elasticity = squeal_stages::artifact::material::isotropic_elasticity(2.02e11, 0.29);
        let started = std::time::Instant::now();
        let volume: f64 = {
            use rayon::prelude::*;
            (0..mesh.elements.len())
                .into_par_iter()
                .map(|e| {
                    let element = mesh.elements.get(e);
                    let coords: Vec<[f64; 3]> = element
                        .nodes
                        .iter()
                        .map(|&n| mesh.nodes[n as usize])
                        .collect();
                    element_matrices(element.kind, &coords, &elasticity, 7850.0)
                        .expect("valid")
                        .volume
                })
                .sum()
        };
        let matrices = mesh.elements.len() as f64 / started.elapsed().as_secs_f64();
        assert!(volume > 0.0);
        println!(
            "{:<8} {:>9} {:>9} {:>12.0} {:>12.0} {:>8.2} {:>14.0}",
            kind.name(),
            mesh.elements.len(),
            3 * mesh.n_nodes(),
            one,
            two,
            two / one,
            matrices
        );
    }
}
