//! The Neo-Hookean law's logarithm (`hyperpbd::core::material::ln`, the
//! CPU side) against the f64 WGSL `ln_real` of `shaders/ln_f64.wgsl`, run
//! on the GPU: equal bit for bit, so an f64 material kernel can repeat the
//! law exactly; and the f32 reference's ln against `shaders/ln_f32.wgsl`
//! in f32, bit for bit where f32 is correctly rounded (lavapipe). Printed
//! as `BOUND | name | measured | bound | rationale`.

use crate::common;

use common::exact::f32_identical;
use common::gpu::adapter_or_skip;
use hyperpbd::barrier::{BarrierLaw, BarrierObstacles};
use hyperpbd::core::material::ln;
use hyperpbd::gpu::Precision;
use hyperpbd::gpu::barrier::BarrierKernels;
use hyperpbd_cpu::f32_reference::ln::ln as ln32;

/// The barrier kernels of a unit law and no obstacles: their `ln_check`
/// entry point runs the shader's ln alone.
fn ln_kernels(adapter: &wgpu::Adapter, precision: Precision) -> BarrierKernels {
    let law = BarrierLaw {
        stiffness: 1.0,
        activation_distance: 1.0,
    };
    BarrierKernels::new(adapter, precision, 1, law, &BarrierObstacles::default()).expect("kernels")
}

#[test]
fn material_ln_equals_the_f64_shader_ln_bit_for_bit() {
    let Some((adapter, _)) = adapter_or_skip(
        "material_ln_equals_the_f64_shader_ln_bit_for_bit",
        Precision::F64,
    ) else {
        return;
    };
    let kernels = ln_kernels(&adapter, Precision::F64);
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

#[test]
fn the_f32_reference_ln_equals_the_f32_shader_ln_bit_for_bit() {
    let Some((adapter, summary)) = adapter_or_skip(
        "the_f32_reference_ln_equals_the_f32_shader_ln_bit_for_bit",
        Precision::F32,
    ) else {
        return;
    };
    if !f32_identical(&summary) {
        println!("f32 ln: this adapter does not promise correctly rounded f32; not compared");
        return;
    }
    let kernels = ln_kernels(&adapter, Precision::F32);
    // Every 4099th positive normal f32 (both ends included: the 2^±64
    // scaling), every f32 within 2^-12 of 1, each side of √2 and of the
    // powers of two.
    let mut values: Vec<f32> = (f32::MIN_POSITIVE.to_bits()..=f32::MAX.to_bits())
        .step_by(4099)
        .map(f32::from_bits)
        .collect();
    values.extend(
        ((1.0f32 - 1.0 / 4096.0).to_bits()..=(1.0f32 + 1.0 / 4096.0).to_bits()).map(f32::from_bits),
    );
    for e in -126..=127 {
        let p = 2f32.powi(e);
        for q in [p, p * std::f32::consts::SQRT_2] {
            values.extend([
                q,
                f32::from_bits(q.to_bits() - 1),
                f32::from_bits(q.to_bits() + 1),
            ]);
        }
    }
    values.retain(|v| v.is_normal());
    values.extend([f32::MIN_POSITIVE, f32::MAX]);
    let inputs: Vec<f64> = values.iter().map(|&v| f64::from(v)).collect();
    let got = kernels.ln(&inputs).expect("ln");
    let mut differing = 0usize;
    for (&v, &g) in values.iter().zip(&got) {
        let expected = ln32(v);
        if (g as f32).to_bits() != expected.to_bits() {
            differing += 1;
            eprintln!("ln({v:e}): GPU {g:e}, f32 reference {expected:e}");
        }
    }
    common::bound::print_bound(
        format_args!(
            "f32 ln: f32 reference vs f32 shader, {} values",
            values.len()
        ),
        format_args!("{differing} differing"),
        0,
        "same operations in the same order, correctly rounded on both sides",
    );
    assert_eq!(differing, 0);
}
