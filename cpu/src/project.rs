//! XPBD projection of one color of one family.
//!
//! ```text
//! α~ = α / h²
//! Δλ = (−C − α~ λ) / (Σ_j w_j |∇_j C|² + α~)
//! inequality (C ≥ 0):  λ' = max(λ + Δλ, 0);  Δλ = λ' − λ
//! x_j += w_j ∇_j C Δλ
//! ```
//! Tethers (|x1 − x0| ≤ rest) are distances with the one-sided clamp
//! λ' = min(λ + Δλ, 0); Δλ = λ' − λ (they only pull).
//!
//! Σ_j w_j |∇_j C|² is w_0 + w_1 for distance and w for contacts (their
//! gradients are unit vectors); measure kinds sum the computed gradients.
//! Expression families run `hyperpbd_core::kinds::project` (one code for
//! f64 here and f32 in the f32 reference; its docs have the update).
//! Material families (`material.rs`) take this generic path with their
//! energy constraint C = √(2W) (rest value 0, compliance 1); a
//! Neo-Hookean element with J ≤ 0 fails its slot like a non-finite update.
//! If that sum is 0 (no dynamic particle, or ∇C = 0: coincident points, a
//! collapsed simplex) the element makes no response. Fixed particles
//! (w = 0) are never written, not even with ±0.
//!
//! A contact checks the raw Δλ for NaN/Inf before the clamp (max(NaN, 0)
//! would hide it).
//!
//! Mesh contacts take the same update with the mesh's normal at x
//! (`mesh_contact_in`; `mesh_contact.rs` has the math).
//!
//! Static friction (hyperplane contact with μ > 0), after the normal update
//! of an active contact (λ > 0):
//! ```text
//! Δx = x − p;  Δt = Δx − (n·Δx) n          (tangential motion this substep)
//! if |Δt| ≤ μ · w λ  (the normal correction):  x −= Δt
//! ```
//! The whole tangent vector is cancelled or none of it — never per axis.
//!
//! Elements of one colour share no dynamic particle (the plan's colouring,
//! checked by `colours.rs` when the backend loads) and only dynamic
//! particles are written, so a colour runs in chunks of [`ELEMENT_GRAIN`]
//! on every core (`parallel.rs`): each element reads what it would read
//! serially and makes the same updates.

// Coordinate loops index several arrays at once, as a kernel does.
#![allow(clippy::needless_range_loop)]

use crate::dim::{Dim, with_dim};
use crate::parallel::{Coordinates, DisjointSlice, Shared, Workers, first_error};
use hyperpbd_core::barrier::BarrierObstacles;
use hyperpbd_core::expr::Columns;
use hyperpbd_core::geometry::{Scratch, oriented_measure, simplex_squared_measure};
use hyperpbd_core::kinds;
use hyperpbd_core::kinds::contact_friction::static_friction;
use hyperpbd_core::kinds::hyperplane_contact::contact_update;
use hyperpbd_core::kinds::mesh_candidates::Candidates;
use hyperpbd_core::material::MaterialScratch;
use hyperpbd_core::motion::MeshAt;
use hyperpbd_core::moving_mesh::closest_placed;
use hyperpbd_core::{Family, FamilyKind, MAX_DIM};
use std::ops::Range;

/// Elements per chunk of a colour (≈ 5 µs of distance projections: a
/// colour up to this size runs on the calling thread; a 64² cloth's
/// colours of 2,048 split in two — `cargo bench --bench cpu_threads`).
pub const ELEMENT_GRAIN: usize = 1024;

/// Inputs shared by every element of a batch.
pub struct Batch<'a> {
    pub dim: usize,
    pub inverse_mass: &'a [f64],
    pub family: &'a Family,
    /// α / h².
    pub alpha_tilde: f64,
    /// Positions at the start of the substep (for static friction).
    pub start: &'a [f64],
    /// The plan's meshes (mesh contact families).
    pub meshes: &'a [std::sync::Arc<hyperpbd_core::barrier::BarrierObstacles>],
    /// A moving mesh family's placement this substep (`None`: static).
    pub moving_mesh: Option<&'a MeshAt>,
    /// A mesh family's kept candidates (`mesh_contact::KeptCandidates`;
    /// empty for other families).
    pub kept: &'a DisjointSlice<'a, Candidates>,
}

/// Per-batch scratch.
#[derive(Default)]
pub struct Workspace {
    pub points: Vec<f64>,
    pub grad: Vec<f64>,
    pub scratch: Scratch,
    /// The material laws' buffers.
    pub material: MaterialScratch,
    /// An expression family's columns (one per tape slot).
    pub columns: Columns<f64>,
    /// An expression family's projection scratch.
    pub projection: kinds::ProjectionScratch<f64>,
}

/// Coordinates as an expression projection reads and writes them.
struct Positions<'a, X: ?Sized>(&'a mut X);

impl<X: Coordinates + ?Sized> kinds::Positions<f64> for Positions<'_, X> {
    #[inline(always)]
    fn values(&self, range: Range<usize>) -> &[f64] {
        self.0.values(range)
    }
    #[inline(always)]
    fn values_mut(&mut self, range: Range<usize>) -> &mut [f64] {
        self.0.values_mut(range)
    }
}

/// Projects elements `range` (one colour's color-ordered slots) of
/// `batch.family`. Returns the slot of the first element whose update was
/// non-finite.
pub fn project(
    workers: &Workers,
    batch: &Batch,
    range: Range<usize>,
    x: &mut [f64],
    lambda: &mut [f64],
    ws: &mut Workspace,
) -> Result<(), usize> {
    if range.len() <= workers.grain(ELEMENT_GRAIN) {
        return project_elements(batch, range.clone(), x, &mut lambda[range], ws);
    }
    project_chunks(workers, batch, range, x, lambda, ws)
}

/// [`project`] of a colour of more than one chunk.
#[inline(never)]
fn project_chunks(
    workers: &Workers,
    batch: &Batch,
    range: Range<usize>,
    x: &mut [f64],
    lambda: &mut [f64],
    ws: &mut Workspace,
) -> Result<(), usize> {
    let first = range.start;
    if !workers.splits(range.len(), ELEMENT_GRAIN) {
        // One thread: the same chunks in order, each to its own first
        // failure, on the plain slice.
        return workers
            .chunks(range.len(), ELEMENT_GRAIN)
            .map(|r| {
                let elements = first + r.start..first + r.end;
                project_elements(batch, elements.clone(), x, &mut lambda[elements], ws)
            })
            .fold(Ok(()), first_error);
    }
    // SAFETY: the elements of `range` form one colour: no two share a
    // dynamic particle (checked by `colours::check` when the backend
    // loaded the plan), and the kernels write only dynamic particles
    // (w ≠ 0), so a written coordinate belongs to exactly one element and
    // hence one chunk; fixed particles are only read.
    let x = unsafe { DisjointSlice::new(x) };
    // SAFETY: each chunk takes the slots of its own elements below.
    let lambda = unsafe { DisjointSlice::new(&mut lambda[range.clone()]) };
    workers.try_for_chunks_with(
        range.len(),
        ELEMENT_GRAIN,
        ws,
        Workspace::default,
        |r, ws| {
            // SAFETY: slots `r` belong to this chunk alone.
            let lambda = unsafe { lambda.range_mut(r.clone()) };
            let elements = first + r.start..first + r.end;
            project_elements(batch, elements, &mut Shared(&x), lambda, ws)
        },
    )
}

/// Projects `elements` in order; `lambda` holds their slots.
fn project_elements<X: Coordinates + ?Sized>(
    batch: &Batch,
    elements: Range<usize>,
    x: &mut X,
    lambda: &mut [f64],
    ws: &mut Workspace,
) -> Result<(), usize> {
    match &batch.family.kind {
        FamilyKind::Distance | FamilyKind::Tether if batch.dim <= MAX_INLINE_DIM => {
            with_dim!(batch.dim, distance_in(batch, elements, x, lambda))
        }
        FamilyKind::HyperplaneContact { normal, friction } => with_dim!(
            batch.dim,
            contact_in(batch, normal, *friction, elements, x, lambda)
        ),
        FamilyKind::MeshContact { mesh, friction } => mesh_contact_in(
            (
                batch.dim,
                batch.inverse_mass,
                batch.alpha_tilde,
                batch.start,
            ),
            batch.family,
            (&batch.meshes[*mesh], batch.moving_mesh, batch.kept),
            *friction,
            elements,
            x,
            lambda,
        ),
        FamilyKind::Distance
        | FamilyKind::Tether
        | FamilyKind::SimplexMeasure { .. }
        | FamilyKind::OrientedMeasure
        | FamilyKind::Material { .. } => {
            with_dim!(batch.dim, measure(batch, elements, x, lambda, ws))
        }
        FamilyKind::Expression(kind) => {
            let colour = kinds::Colour {
                kind,
                dim: batch.dim,
                elements: &batch.family.elements,
                rest: &batch.family.rest,
                constants: &kind.constants,
                alpha_tilde: batch.alpha_tilde,
                inverse_mass: batch.inverse_mass,
                slots: elements,
            };
            kinds::project(&colour, &mut Positions(x), lambda, &mut ws.projection)
        }
    }
}

/// Largest dimension whose distance difference vector lives on the stack.
const MAX_INLINE_DIM: usize = 8;

/// Distance projection: the same arithmetic, in the same order, as the
/// generic path with `geometry::distance` (which is its reference).
fn distance_in<D: Dim, X: Coordinates + ?Sized>(
    dim: D,
    batch: &Batch,
    elements: Range<usize>,
    x: &mut X,
    lambda: &mut [f64],
) -> Result<(), usize> {
    let n = dim.n();
    let f = batch.family;
    let w = batch.inverse_mass;
    let alpha_tilde = batch.alpha_tilde;
    let tether = f.kind == FamilyKind::Tether;
    let ends = f.elements[2 * elements.start..2 * elements.end].chunks_exact(2);
    let slots = f.rest[elements.clone()].iter().zip(lambda.iter_mut());
    for (e, (element, (&rest, lambda))) in elements.zip(ends.zip(slots)) {
        let (i, j) = (element[0] as usize, element[1] as usize);
        let (wi, wj) = (w[i], w[j]);
        let mut d = [0.0; MAX_INLINE_DIM];
        let mut d2 = 0.0;
        {
            let (xi, xj) = (x.values(i * n..i * n + n), x.values(j * n..j * n + n));
            for a in 0..n {
                d[a] = xj[a] - xi[a];
                d2 += d[a] * d[a];
            }
        }
        let len = d2.sqrt();
        let wsum = wi + wj;
        if len.is_nan() || len <= 0.0 || wsum == 0.0 {
            if !len.is_finite() {
                return Err(e);
            }
            continue;
        }
        let c = len - rest;
        let mut dl = (-c - alpha_tilde * *lambda) / (wsum + alpha_tilde);
        if !dl.is_finite() {
            return Err(e);
        }
        if tether {
            dl = (*lambda + dl).min(0.0) - *lambda;
        }
        *lambda += dl;
        let inv = 1.0 / len;
        for c in &mut d[..n] {
            *c *= inv;
        }
        if wi != 0.0 {
            let xi = x.values_mut(i * n..i * n + n);
            for a in 0..n {
                xi[a] += wi * -d[a] * dl;
            }
        }
        if wj != 0.0 {
            let xj = x.values_mut(j * n..j * n + n);
            for a in 0..n {
                xj[a] += wj * d[a] * dl;
            }
        }
    }
    Ok(())
}

/// Generic path: gather, evaluate C and ∇C, update.
fn measure<D: Dim, X: Coordinates + ?Sized>(
    dim: D,
    batch: &Batch,
    elements: Range<usize>,
    x: &mut X,
    lambda: &mut [f64],
    ws: &mut Workspace,
) -> Result<(), usize> {
    let dim = dim.n();
    let f = batch.family;
    let w = batch.inverse_mass;
    let arity = f.arity;
    let first = elements.start;
    ws.points.resize(arity * dim, 0.0);
    ws.grad.resize(arity * dim, 0.0);
    for e in elements {
        let element = &f.elements[e * arity..(e + 1) * arity];
        for (j, &i) in element.iter().enumerate() {
            let i = i as usize;
            ws.points[j * dim..(j + 1) * dim].copy_from_slice(x.values(i * dim..(i + 1) * dim));
        }
        let value = gathered_value(f, e, dim, ws)?;
        if !value.is_finite() {
            return Err(e);
        }
        let mut wsum = 0.0;
        if matches!(f.kind, FamilyKind::Distance | FamilyKind::Tether) {
            if value > 0.0 {
                wsum = w[element[0] as usize] + w[element[1] as usize];
            }
        } else {
            for (j, &i) in element.iter().enumerate() {
                let g2: f64 = ws.grad[j * dim..(j + 1) * dim].iter().map(|g| g * g).sum();
                wsum += w[i as usize] * g2;
            }
        }
        if wsum == 0.0 {
            continue;
        }
        let lambda = &mut lambda[e - first];
        let c = value - f.rest[e];
        let mut dl = (-c - batch.alpha_tilde * *lambda) / (wsum + batch.alpha_tilde);
        if !dl.is_finite() {
            return Err(e);
        }
        if f.kind == FamilyKind::Tether {
            dl = (*lambda + dl).min(0.0) - *lambda;
        }
        *lambda += dl;
        for (j, &i) in element.iter().enumerate() {
            let i = i as usize;
            let wi = w[i];
            if wi == 0.0 {
                continue;
            }
            let xi = x.values_mut(i * dim..(i + 1) * dim);
            for a in 0..dim {
                xi[a] += wi * ws.grad[j * dim + a] * dl;
            }
        }
    }
    Ok(())
}

/// C and ∇C (into `ws.grad`) of slot `e` of a gradient-based family
/// (distance, tether, measures, materials) at the points gathered into
/// `ws.points`. A material refusal, or a contact or expression family (they
/// take their own paths), fails the slot.
pub(crate) fn gathered_value(
    f: &Family,
    e: usize,
    dim: usize,
    ws: &mut Workspace,
) -> Result<f64, usize> {
    Ok(match &f.kind {
        FamilyKind::Distance | FamilyKind::Tether => {
            hyperpbd_core::geometry::distance(&ws.points, dim, &mut ws.grad)
        }
        FamilyKind::SimplexMeasure { .. } => {
            simplex_squared_measure(&ws.points, dim, &mut ws.grad, &mut ws.scratch)
        }
        FamilyKind::Material { .. } => {
            // A refusal fails the slot; `element_refusal` names it.
            crate::material::energy_constraint(
                f,
                e,
                &ws.points,
                dim,
                &mut ws.grad,
                &mut ws.material,
            )
            .map_err(|_| e)?
        }
        FamilyKind::OrientedMeasure => {
            oriented_measure(&ws.points, dim, &mut ws.grad, &mut ws.scratch)
        }
        // Contacts take `contact_in` and expressions `kinds::project`,
        // never this path.
        FamilyKind::HyperplaneContact { .. }
        | FamilyKind::MeshContact { .. }
        | FamilyKind::Expression(_) => return Err(e),
    })
}

fn contact_in<D: Dim, X: Coordinates + ?Sized>(
    dim: D,
    batch: &Batch,
    normal: &[f64],
    friction: f64,
    elements: Range<usize>,
    x: &mut X,
    lambda: &mut [f64],
) -> Result<(), usize> {
    let n = dim.n();
    let normal = &normal[..n];
    let f = batch.family;
    let alpha_tilde = batch.alpha_tilde;
    let slots = f.rest[elements.clone()].iter().zip(lambda.iter_mut());
    for (e, (&i, (&rest, lambda))) in elements.clone().zip(f.elements[elements].iter().zip(slots)) {
        let i = i as usize;
        let w = batch.inverse_mass[i];
        let xi = x.values_mut(i * n..i * n + n);
        let c = dot(normal, xi) - rest;
        *lambda = contact_update(c, (*lambda, w, alpha_tilde), normal, xi).ok_or(e)?;
        if friction > 0.0 && *lambda > 0.0 {
            let p = &batch.start[i * n..i * n + n];
            static_friction(normal, friction * w * *lambda, p, xi);
        }
    }
    Ok(())
}

/// Projects elements `elements` of mesh family `family` (`mesh_contact.rs`
/// has the update; a moving mesh is queried in its frame and its static
/// friction measured against the carried point q = p + D(p), as a moving
/// plane's: `hyperpbd_core::moving_mesh`) (`lambda`: their slots); the
/// first slot whose update was not finite.
#[allow(clippy::too_many_arguments)]
fn mesh_contact_in<X: Coordinates + ?Sized>(
    (dim, inverse_mass, alpha_tilde, start): (usize, &[f64], f64, &[f64]),
    family: &Family,
    (mesh, moving, kept): (
        &BarrierObstacles,
        Option<&MeshAt>,
        &DisjointSlice<Candidates>,
    ),
    friction: f64,
    elements: Range<usize>,
    x: &mut X,
    lambda: &mut [f64],
) -> Result<(), usize> {
    let n = dim;
    let mut normal = [0.0f64; MAX_DIM];
    let normal = &mut normal[..n];
    let mut carried = [0.0f64; MAX_DIM];
    let q = &mut carried[..n];
    let frame = moving.map(|m| m.frame(&[]));
    // SAFETY: `elements` are this call's alone (one chunk of a colour, or
    // the whole colour on one thread), and an element's slot is touched
    // only by its own update.
    let kept = unsafe { kept.range_mut(elements.clone()) };
    let first = elements.start;
    for e in elements {
        let i = family.elements[e] as usize;
        let w = inverse_mass[i];
        let l = lambda[e - first];
        let xi = x.values_mut(i * n..i * n + n);
        let query = (&*xi, family.rest[e], w * l);
        let slot = Some(&mut kept[e - first]);
        let Some(c) = closest_placed(mesh, frame.as_ref(), query, normal, slot) else {
            continue;
        };
        lambda[e - first] = contact_update(c, (l, w, alpha_tilde), normal, xi).ok_or(e)?;
        if friction > 0.0 && lambda[e - first] > 0.0 {
            let p = &start[i * n..i * n + n];
            let bound = friction * w * lambda[e - first];
            match moving {
                None => static_friction(normal, bound, p, xi),
                Some(m) => {
                    m.carry.at(p, q);
                    for a in 0..n {
                        q[a] += p[a];
                    }
                    static_friction(normal, bound, q, xi);
                }
            }
        }
    }
    Ok(())
}

/// n·x.
pub fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}
