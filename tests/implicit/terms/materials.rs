//! Material Hessians against finite differences, projected in frame
//! coordinates.

use super::*;

/// The rest data and a deformed state of one element.
fn material_case(dim: usize, k: usize, amount: f64, rng: &mut Lcg) -> (Vec<f64>, f64, Vec<f64>) {
    let rest = simplex(dim, k, rng);
    let mut frame = vec![0.0; k * k];
    let measure = rest_element(&rest, dim, &mut frame, &mut MaterialScratch::new()).expect("rest");
    let mut a: Vec<f64> = (0..dim * dim).map(|_| amount * rng.next()).collect();
    for i in 0..dim {
        a[i * dim + i] += 1.0;
    }
    let mut x = Vec::new();
    for point in rest.chunks(dim) {
        x.extend(mat_vec(&a, point).iter().map(|v| v + 0.01 * rng.next()));
    }
    (frame, measure, x)
}

#[test]
fn material_hessians_match_finite_differences_and_project_in_frame_coordinates() {
    let mut rng = Lcg(1603);
    let (mut worst_h, mut worst_psd, mut worst_diag) = (0.0f64, 0.0f64, 0.0f64);
    let (mut clipped_cases, mut kept_cases) = (0, 0);
    for law in [Law::StVenantKirchhoff, Law::NeoHookean] {
        for dim in [1, 2, 3, 4, 8] {
            let mut orders = vec![1, dim];
            if dim >= 3 {
                orders.push(2);
            }
            orders.dedup();
            for k in orders {
                for amount in [0.02, 0.35] {
                    let material = Material::new(law, k, 5.0, 0.3 / k as f64).expect("material");
                    let (frame, measure, x) = material_case(dim, k, amount, &mut rng);
                    let rest = RestView {
                        frame: &frame,
                        measure,
                    };
                    let count = (k + 1) * dim;
                    let size = dim * k;
                    let mut hs = MaterialHessianScratch::new();
                    let term = |y: &[f64], hf: &mut Vec<f64>| {
                        let mut g = vec![0.0; count];
                        hf.resize(size * size, 0.0);
                        let mut s = MaterialScratch::new();
                        let mut h = MaterialHessianScratch::new();
                        let element = MaterialElement {
                            material: &material,
                            points: y,
                            dim,
                            rest,
                        };
                        material_term(element, &mut g, hf, &mut s, &mut h).map(|_| g)
                    };
                    let mut frame_hessian = Vec::new();
                    let Ok(_) = term(&x, &mut frame_hessian) else {
                        continue;
                    };
                    let mut exact = vec![0.0; count * count];
                    material_hessian_block(&frame_hessian, rest, dim, k + 1, &mut exact, &mut hs);
                    let gradient = |y: &[f64]| term(y, &mut Vec::new()).expect("law");
                    worst_h = worst_h.max(jacobian_worst(&gradient, &x, &exact, 1e-4));
                    // Project H_F; the vertex block is PSD; unchanged when PSD.
                    let mut projected = frame_hessian.clone();
                    let report = project_psd(&mut projected, size, &mut PsdScratch::new());
                    assert!(report.finite && report.eigen.converged, "{report:?}");
                    if report.clipped == 0 {
                        kept_cases += 1;
                        assert_eq!(projected, frame_hessian);
                    } else {
                        clipped_cases += 1;
                    }
                    let mut block = vec![0.0; count * count];
                    material_hessian_block(&projected, rest, dim, k + 1, &mut block, &mut hs);
                    let scale = max_abs(&block).max(1e-300);
                    worst_psd = worst_psd.max(-eigenvalues(&block, count)[0] / scale);
                    let mut diagonal = vec![0.0; count];
                    material_curvature_diagonal(&projected, rest, dim, &mut diagonal, &mut hs);
                    for i in 0..count {
                        worst_diag =
                            worst_diag.max((diagonal[i] - block[i * count + i]).abs() / scale);
                    }
                }
            }
        }
    }
    println!("material cases: {kept_cases} PSD as is, {clipped_cases} clipped");
    assert!(
        kept_cases > 0 && clipped_cases > 0,
        "both branches must be exercised"
    );
    bound(
        "material exact Hessian vs FD",
        worst_h,
        1.0,
        "Richardson + rounding model",
    );
    bound(
        "material projected block min eigenvalue / max entry",
        worst_psd,
        1e-13,
        "PSD to rounding (Nk ≤ 64)",
    );
    bound(
        "material diagonal vs dense / max entry",
        worst_diag,
        1e-13,
        "same sums, other order",
    );
}
