//! Every kernel alone on every case, f32 and f64.

use super::*;

use super::cases::{chain, chain3d, contacts, tesseract_jittered, triangles3d};
use super::pair::Pair;

/// Every case of this file for one precision.
fn all_kernels(precision: Precision, test: &str) {
    let Some((adapter, _)) = adapter_or_skip(test, precision) else {
        return;
    };
    for (dim, n) in [(6, 37), (8, 37)] {
        Pair::new(
            &adapter,
            &chain(dim, n),
            precision,
            &format!("distance chain {dim}D({n})"),
        )
        .every_color();
    }
    for n in [37, 129] {
        Pair::new(
            &adapter,
            &chain3d(n),
            precision,
            &format!("distance chain3d({n})"),
        )
        .every_color();
    }
    Pair::new(
        &adapter,
        &triangles3d(37),
        precision,
        "simplex_measure k=2 triangles3d(37)",
    )
    .every_color();
    Pair::new(
        &adapter,
        &tesseract_jittered(),
        precision,
        "oriented_measure tesseract 4D",
    )
    .every_color();
    for (dim, n) in [(3, 129), (5, 37)] {
        Pair::new(
            &adapter,
            &contacts(dim, n),
            precision,
            &format!("contact+friction {dim}D({n})"),
        )
        .every_color();
    }
    // One particle: its only family is the plane contact; it penetrates and
    // slides.
    Pair::new(
        &adapter,
        &contacts(3, 1),
        precision,
        "one particle contact 3D(1)",
    )
    .every_color();
}

#[test]
fn every_kernel_alone_matches_the_cpu_f32() {
    all_kernels(Precision::F32, "every_kernel_alone_matches_the_cpu_f32");
}

#[test]
fn every_kernel_alone_matches_the_cpu_f64() {
    all_kernels(Precision::F64, "every_kernel_alone_matches_the_cpu_f64");
}
