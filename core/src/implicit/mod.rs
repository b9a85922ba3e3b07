//! The terms of the coupled implicit step (the incremental potential grown
//! up), independent of any backend: elastic springs and materials with
//! their projected curvature, the ball–ball barrier, lagged friction, the
//! certified step filters, PSD projection, a matrix-free preconditioned CG
//! and the fixed reduction tree both backends follow.
//!
//! ```text
//! F(x) = ½ ‖x − x~‖²_M + h² U(x)                      (mass·length², like today)
//! U(x) = Σ_i −(m_i s_i g + f_i)·x_i                    external load (as today)
//!      + Σ_springs C_e(x)² / (2 α_e)                   distance, tether (stretched only),
//!                                                      simplex measure, oriented measure
//!      + Σ_materials V_0 Ψ(F̂_e)                        StVK, Neo-Hookean (material module)
//!      + Σ_{i, o} b(d_io(x_i))                         particle–obstacle barriers (barrier.rs)
//!      + Σ_{i<j} b(|x_i − x_j| − r_i − r_j)            ball–ball barriers
//!      + Σ_contacts μ λ_lag f₀(|P_lag Δu|)             lagged friction (energy units)
//! ∇F   = M (x − x~) + h² ∇U
//! H⁺   = M + h² Σ_e S_eᵀ K_e⁺ S_e                      element blocks, each PSD
//! ```
//! Every element's curvature is PSD before it is used: exactly projected
//! in closed form for the radial terms (distance, tether, ball pair), PSD
//! by construction for the Gauss–Newton measure springs and for friction,
//! projected by the deterministic eigensolver ([`project_psd`]) for
//! materials. So H⁺ is SPD over the free particles and preconditioned CG
//! ([`pcg`]) finds a descent direction. The step is cut by the certified
//! filters ([`certified_filter`]) before a line search evaluates anything.
//!
//! All code here is plain f64 arithmetic in fixed loop orders (ascending
//! indices, `s = 0; s += …`), with `sqrt` as the only non-arithmetic
//! operation, so an f64 WGSL kernel can repeat it bit for bit. The whole
//! derivation, units and the step algorithm are in docs/implicit.md.

// Index loops mirror the math (and the later WGSL port) line by line.
#![allow(clippy::needless_range_loop)]

mod ball_barrier;
pub mod certified_filter;
pub mod closed_forms;
mod element_lists;
mod expression_spring;
mod friction;
pub mod line_search;
mod material_hessian;
mod material_rounding;
mod pcg;
mod psd;
mod radial;
mod reduction;
pub mod resolution;
mod springs;
mod step_plan;

pub use ball_barrier::{BallPair, ball_pair_barrier};
pub use element_lists::ElementLists;
pub use expression_spring::{
    ExpressionScratch, ExpressionSpring, apply_dense, expression_curvature, expression_rounding,
    expression_spring,
};
pub use friction::{
    FrictionRegime, FrictionTerm, PairLag, TangentCurvature, mollifier, normal_force,
    obstacle_friction, pair_friction, pair_lags,
};
pub use material_hessian::{
    FrameLaw, MaterialHessianScratch, apply_material_curvature, curvature_product,
    frame_hessian_of, material_curvature_diagonal, material_hessian_block, material_term,
};
pub use material_rounding::material_energy_rounding;
pub use pcg::{
    PcgReport, PcgSettings, PcgStatus, PcgVectors, PcgWorkspace, newton_cg_tolerance, pcg, pcg_on,
    pcg_start,
};
pub use psd::{PsdProjection, PsdScratch, project_psd};
pub use radial::RadialCurvature;
pub use reduction::{REDUCTION_BLOCK, block_tree_max, block_tree_sum, tree_dot};
pub use springs::{Spring, SpringCurvature, evaluate_spring};
pub use step_plan::CoupledPlan;
