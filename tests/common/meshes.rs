//! Simplex meshes of the tests: a flat triangulated floor in any dimension.

use hyperpbd::Obstacle;
use hyperpbd::motion::Motion;

/// A flat floor x_1 = `height` of R^`dim`: the grid [−half, half]^(N−1)
/// of the other axes, `cells` cells a side, each cube cut into (N−1)!
/// simplices (Kuhn: [c, c + e_π0, c + e_π0 + e_π1, …] per permutation π).
pub fn floor(dim: usize, height: f64, half: f64, cells: usize, friction: f64) -> Obstacle {
    let k = dim - 1;
    let axes: Vec<usize> = (0..dim).filter(|&a| a != 1).collect();
    let side = cells + 1;
    let index = |c: &[usize]| c.iter().fold(0, |acc, &ci| acc * side + ci);
    let mut vertices = Vec::new();
    for v in 0..side.pow(k as u32) {
        let mut x = vec![0.0; dim];
        x[1] = height;
        let mut rest = v;
        for j in (0..k).rev() {
            x[axes[j]] = -half + 2.0 * half * (rest % side) as f64 / cells as f64;
            rest /= side;
        }
        vertices.push(x);
    }
    let mut permutations = vec![vec![]];
    for n in 0..k {
        permutations = permutations
            .into_iter()
            .flat_map(|p: Vec<usize>| {
                (0..=n).map(move |at| {
                    let mut q = p.clone();
                    q.insert(at, n);
                    q
                })
            })
            .collect();
    }
    let mut simplices = Vec::new();
    for cube in 0..cells.pow(k as u32) {
        let mut corner = vec![0; k];
        let mut rest = cube;
        for j in (0..k).rev() {
            corner[j] = rest % cells;
            rest /= cells;
        }
        for p in &permutations {
            let mut c = corner.clone();
            let mut simplex = vec![index(&c)];
            for &axis in p {
                c[axis] += 1;
                simplex.push(index(&c));
            }
            simplices.push(simplex);
        }
    }
    Obstacle::SimplexMesh {
        vertices,
        simplices,
        friction,
        motion: Vec::new(),
    }
}

/// [`floor`], moving by `motion`.
pub fn moving_floor(
    dim: usize,
    (height, half, cells): (f64, f64, usize),
    friction: f64,
    motion: Vec<Motion>,
) -> Obstacle {
    let mut mesh = floor(dim, height, half, cells, friction);
    if let Obstacle::SimplexMesh { motion: moves, .. } = &mut mesh {
        *moves = motion;
    }
    mesh
}
