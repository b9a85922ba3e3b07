//! The Neo-Hookean law's logarithm (`hyperpbd::core::material::ln`, the
//! CPU side) against the f64 WGSL `ln_real` of `shaders/ln_f64.wgsl`, run
//! on the GPU: equal bit for bit, so an f64 material kernel can repeat the
//! law exactly. Printed as `BOUND | name | measured | bound | rationale`.

mod common;

use common::gpu::adapter_or_skip;
use hyperpbd::barrier::{BarrierLaw, BarrierObstacles};
use hyperpbd::core::material::ln;
use hyperpbd::gpu::Precision;
use hyperpbd::gpu::barrier::BarrierKernels;

#[test]
fn material_ln_equals_the_f64_shader_ln_bit_for_bit() {
    let Some((adapter, _)) = adapter_or_skip(
        "material_ln_equals_the_f64_shader_ln_bit_for_bit",
        Precision::F64,
    ) else {
        return;
    };
    let law = BarrierLaw {
        stiffness: 1.0,
        activation_distance: 1.0,
    };
    let kernels = BarrierKernels::new(
        &adapter,
        Precision::F64,
        1,
        law,
        &BarrierObstacles::default(),
    )
    .expect("kernels");
    // The measure ratios a material sees (around 1, both sides of each
    // power of two and of √2), plus the whole positive range.
    let mut values = Vec::new();
    for i in 1..=4000 {
        values.push(i as f64 / 1000.0);
    }
    for k in -600..=600 {
        values.push(10f64.powf(k as f64 / 2.0));
        values.push(1.7 * 10f64.powf(k as f64 / 2.0));
    }
    for e in -60..=60 {
        let p = 2f64.powi(e);
        values.extend([
            p,
            p * (1.0 - f64::EPSILON),
            p * (1.0 + f64::EPSILON),
            p * std::f64::consts::SQRT_2,
            p * std::f64::consts::SQRT_2 * (1.0 + f64::EPSILON),
        ]);
    }
    for k in 1..=15 {
        let t = 10f64.powi(-k);
        values.extend([1.0 + t, 1.0 - t]);
    }
    values.extend([f64::MIN_POSITIVE, 5e-324, f64::MAX]);
    let got = kernels.ln(&values).expect("ln");
    let mut differing = 0usize;
    for (&v, &g) in values.iter().zip(&got) {
        if g.to_bits() != ln(v).to_bits() {
            differing += 1;
            eprintln!("ln({v:e}): GPU {g:e}, CPU {:e}", ln(v));
        }
    }
    common::bound::print_bound(
        format_args!("material ln: CPU vs f64 shader, {} values", values.len()),
        format_args!("{differing} differing"),
        0,
        "same operations in the same order, correctly rounded on both sides",
    );
    assert_eq!(differing, 0);
}
