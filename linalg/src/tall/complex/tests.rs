use super::*;
use crate::rng::SplitMix64;

fn random(rows: usize, cols: usize, random: &mut SplitMix64) -> Mat<c64> {
    Mat::from_fn(rows, cols, |_, _| {
        c64::new(random.next_signed(), random.next_signed())
    })
}

fn largest_difference(a: MatRef<'_, c64>, b: MatRef<'_, c64>) -> f64 {
    let mut worst = 0.0f64;
    for j in 0..a.ncols() {
        for i in 0..a.nrows() {
            worst = worst.max((a[(i, j)] - b[(i, j)]).norm());
        }
    }
    worst
}

/// The result does not depend on the thread count: the rows are cut the same way and the
/// partial sums added in the same order on any pool.
#[test]
fn products_are_bit_identical_on_any_thread_count() {
    let mut rng = SplitMix64::new(11);
    let (rows, depth, width) = (9_000, 40, 8);
    let Q = random(rows, depth, &mut rng);
    let W = random(rows, width, &mut rng);
    let C = random(depth, width, &mut rng);
    let products = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| {
                let par = Par::rayon(threads);
                let H = adjoint_times(Q.as_ref(), W.as_ref(), par);
                let mut X = W.clone();
                add_times(X.as_mut(), Q.as_ref(), C.as_ref(), par);
                let mut Z = W.clone();
                let P = subtract_then_adjoint_times(Z.as_mut(), Q.as_ref(), C.as_ref(), par);
                (H, X, Z, P)
            })
    };
    let sequential = {
        let H = adjoint_times(Q.as_ref(), W.as_ref(), Par::Seq);
        let mut X = W.clone();
        add_times(X.as_mut(), Q.as_ref(), C.as_ref(), Par::Seq);
        let mut Z = W.clone();
        let P = subtract_then_adjoint_times(Z.as_mut(), Q.as_ref(), C.as_ref(), Par::Seq);
        (H, X, Z, P)
    };
    for threads in [1, 2, 3] {
        assert!(products(threads) == sequential, "{threads} threads");
    }
}

/// The wide tiles (AVX-512) and the narrow ones (AVX2) sum every entry in the same order:
/// their results are bit-identical, so the choice of tile never changes a result.
#[cfg(target_arch = "x86_64")]
#[test]
fn wide_and_narrow_tiles_give_the_same_bits() {
    if !(is_x86_feature_detected!("avx512f") && is_x86_feature_detected!("avx512vl")) {
        return;
    }
    let mut rng = SplitMix64::new(5);
    for &(rows, depth, width) in &[(257usize, 9usize, 8usize), (1031, 64, 16), (33, 5, 3)] {
        let Q = random(rows, depth, &mut rng);
        let W = random(rows, width, &mut rng);
        let C = random(depth, width, &mut rng);
        let (mut narrow, mut wide) = (
            Mat::<c64>::zeros(depth, width),
            Mat::<c64>::zeros(depth, width),
        );
        // SAFETY: AVX-512F, VL (and with them AVX2 and FMA) were detected; `Mat` views have
        // unit row strides.
        unsafe {
            avx::add_adjoint_times(narrow.as_mut(), Q.as_ref(), W.as_ref());
            avx::add_adjoint_times_wide(wide.as_mut(), Q.as_ref(), W.as_ref());
        }
        assert!(narrow == wide, "Q^H W, {rows} x {depth} x {width}");
        let (mut narrow, mut wide) = (W.clone(), W.clone());
        // SAFETY: as above.
        unsafe {
            avx::add_times(narrow.as_mut(), Q.as_ref(), C.as_ref());
            avx::add_times_wide(wide.as_mut(), Q.as_ref(), C.as_ref());
        }
        assert!(narrow == wide, "Q C, {rows} x {depth} x {width}");
    }
}

/// Every tile shape and remainder (odd rows, depths and widths around the tile size of
/// two, several chunks, views with padded column strides), on one and two threads, against
/// faer's product: entries of order one summed over at most 4,099 rows (several strips of
/// the fused update and projection), so 1e-11 is round-off.
#[test]
fn the_tall_product_equals_faers() {
    let mut rng = SplitMix64::new(7);
    for &rows in &[1usize, 2, 5, 131, 4099] {
        for &depth in &[1usize, 2, 3, 4, 5, 9, 130, 259] {
            for &width in &[1usize, 2, 3, 8, 16] {
                // Views into larger matrices, so that column strides exceed the rows.
                let big_q = random(rows + 3, depth + 1, &mut rng);
                let Q = big_q.submatrix(1, 1, rows, depth);
                let W = random(rows, width, &mut rng);
                let reference = Q.adjoint() * &W;
                let C = random(depth, width, &mut rng);
                let updated = &W + &(Q * &C);
                for par in [Par::Seq, Par::rayon(2)] {
                    let h = adjoint_times(Q, W.as_ref(), par);
                    assert!(
                        largest_difference(h.as_ref(), reference.as_ref()) < 1e-11,
                        "Qᴴ W, {rows} × {depth} against {width}, {par:?}"
                    );
                    let mut big_x = random(rows + 2, width + 1, &mut rng);
                    big_x.submatrix_mut(2, 0, rows, width).copy_from(&W);
                    add_times(big_x.submatrix_mut(2, 0, rows, width), Q, C.as_ref(), par);
                    assert!(
                        largest_difference(big_x.submatrix(2, 0, rows, width), updated.as_ref())
                            < 1e-11,
                        "W + Q C, {rows} × {depth} against {width}, {par:?}"
                    );
                    let mut z = updated.clone();
                    let projected = subtract_then_adjoint_times(z.as_mut(), Q, C.as_ref(), par);
                    let errors = [
                        largest_difference(z.as_ref(), W.as_ref()),
                        largest_difference(projected.as_ref(), reference.as_ref()),
                    ];
                    assert!(
                        errors.iter().all(|error| *error < 1e-11),
                        "W + Q C − Q C and its projection, {rows} × {depth} against {width}, {par:?}: {errors:?}"
                    );
                }
            }
        }
    }
}

/// Both tile sizes, whichever the processor would pick: the narrow tiles (AVX2) and, where
/// the processor has AVX-512, the wide ones, on one chunk against faer's product.
#[cfg(target_arch = "x86_64")]
#[test]
fn both_tile_sizes_equal_faers_product() {
    if !(is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma")) {
        return;
    }
    let mut rng = SplitMix64::new(13);
    let rows = 301;
    for &depth in &[1usize, 2, 3, 4, 5, 7, 130] {
        for &width in &[1usize, 2, 3, 4, 5, 8] {
            let Q = random(rows, depth, &mut rng);
            let W = random(rows, width, &mut rng);
            let C = random(depth, width, &mut rng);
            let adjoint = Q.adjoint() * &W;
            let updated = &W + &Q * &C;
            for wide in [false, true] {
                if wide && !wide_tiles() {
                    continue;
                }
                let mut H = Mat::<c64>::zeros(depth, width);
                let mut X = W.clone();
                // SAFETY: the features were detected; the operands are whole matrices.
                unsafe {
                    if wide {
                        avx::add_adjoint_times_wide(H.as_mut(), Q.as_ref(), W.as_ref());
                        avx::add_times_wide(X.as_mut(), Q.as_ref(), C.as_ref());
                    } else {
                        avx::add_adjoint_times(H.as_mut(), Q.as_ref(), W.as_ref());
                        avx::add_times(X.as_mut(), Q.as_ref(), C.as_ref());
                    }
                }
                let errors = [
                    largest_difference(H.as_ref(), adjoint.as_ref()),
                    largest_difference(X.as_ref(), updated.as_ref()),
                ];
                assert!(
                    errors.iter().all(|error| *error < 1e-11),
                    "{depth} × {width}, wide {wide}: errors {errors:?}"
                );
            }
        }
    }
}
