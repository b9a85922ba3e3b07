//! The peer cloth: the benchmark scene a hand-written single-kernel cloth
//! solver (benches/peers/taichi_cloth.py) runs as well, so the golden
//! path can be timed against a peer on the same machine.
//!
//! ```text
//! nodes     n × n, 1 m square, spacing 1/(n − 1), in the x–z plane at y = 1
//!           node (a, b) = particle a + n b, mass 1/n² each
//! fixed     the two corners of the far edge: (0, n − 1) and (n − 1, n − 1)
//! families  the structural edges in four independent sets, projected in
//!           this Gauss–Seidel order, compliance 0:
//!             0  horizontal, a even:  (a, b)–(a + 1, b)
//!             1  horizontal, a odd:   (a, b)–(a + 1, b)
//!             2  vertical,   b even:  (a, b)–(a, b + 1)
//!             3  vertical,   b odd:   (a, b)–(a, b + 1)
//!           (no two edges of one set share a node, so each set is one
//!           colour: the usual colouring of a Taichi/GPU XPBD cloth)
//! time      dt 1/60, 10 substeps × 1 iteration, gravity 9.81 along −y,
//!           no obstacle, no damping
//! ```

use hyperpbd_core::{ConstraintFamily, ConstraintKind, Particle, Scene, SceneBuilder};

/// The `n × n` peer cloth (n ≥ 2).
pub fn peer_cloth(n: usize) -> Scene {
    let n = n.max(2);
    let spacing = 1.0 / (n - 1) as f64;
    let mass = 1.0 / (n * n) as f64;
    let mut b = SceneBuilder::new(3)
        .dt(1.0 / 60.0)
        .substeps(10)
        .iterations(1)
        .gravity_along(1, 9.81);
    let half = 0.5;
    for row in 0..n {
        for column in 0..n {
            let position = vec![
                column as f64 * spacing - half,
                1.0,
                row as f64 * spacing - half,
            ];
            b.particle(Particle::new(position, mass));
        }
    }
    let node = |column: usize, row: usize| column + n * row;
    b.fix(node(0, n - 1));
    b.fix(node(n - 1, n - 1));
    for parity in [0, 1] {
        let edges = (0..n)
            .flat_map(|row| {
                (parity..n - 1)
                    .step_by(2)
                    .map(move |column| vec![node(column, row), node(column + 1, row)])
            })
            .collect();
        b.family(ConstraintFamily::new(ConstraintKind::Distance, 0.0, edges));
    }
    for parity in [0, 1] {
        let edges = (parity..n - 1)
            .step_by(2)
            .flat_map(|row| {
                (0..n).map(move |column| vec![node(column, row), node(column, row + 1)])
            })
            .collect();
        b.family(ConstraintFamily::new(ConstraintKind::Distance, 0.0, edges));
    }
    super::built(b)
}
