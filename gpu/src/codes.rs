//! The integer codes the host and the WGSL share, defined once: each
//! `codes!` table below declares the Rust constants and the list that
//! [`crate::shader::compose`] writes into every module's generated header
//! (`const OP_PREDICT: u32 = 0u;` …), so no shader keeps a copy by hand
//! (`tests/gpu/shaders.rs` refuses a shader file that defines one).
//!
//! ```text
//! OP_*        what one step call runs (step.wgsl's Call.op)
//! FLAG_*      bits of Call.flags (step.wgsl; the coupled step's material
//!             blocks carry FLAG_NEO_HOOKEAN too)
//! IO_*        records a per-particle call loads and stores
//! RESIDUAL_*  Call.kind of a residual call: how residual.wgsl measures a family
//! ELEMENT_*   the coupled step's element codes (coupled.wgsl)
//! ```

use hyperpbd_core::FamilyKind;

/// Declares `pub const NAME: u32 = value;` for each line, and the
/// table `$table` of (name, value) pairs in the same order.
macro_rules! codes {
    ($(#[$doc:meta])* $table:ident { $($(#[$item:meta])* $name:ident = $value:expr;)* }) => {
        $(
            #[doc = concat!("`", stringify!($name), "` = ", stringify!($value), ".")]
            $(#[$item])*
            pub const $name: u32 = $value;
        )*
        $(#[$doc])*
        pub const $table: &[(&str, u32)] = &[$((stringify!($name), $name)),*];
    };
}

codes! {
    /// Step call op codes.
    OPS {
        OP_PREDICT = 0;
        OP_PROJECT_DISTANCE = 1;
        OP_PROJECT_SIMPLEX = 2;
        OP_PROJECT_ORIENTED = 3;
        OP_PROJECT_CONTACT = 4;
        OP_VELOCITY = 5;
        OP_FRICTION = 6;
        OP_DAMPING = 7;
        OP_RESIDUAL = 8;
        OP_GUARD_MEASURE = 9;
        OP_GUARD_SPEED = 10;
        OP_PROJECT_MATERIAL = 11;
        /// An expression family (xpbd/expression.rs).
        OP_PROJECT_EXPRESSION = 12;
        /// Prescribed motion: animated pins placed (xpbd/motion.rs).
        OP_MOTION = 13;
        /// A kernel the host runs itself between dispatches (broadphase,
        /// particle contact): no block of its own is ever executed.
        OP_HOST = 0xff;
        /// No call (a `particles` pipeline's unused op slots).
        OP_NONE = 0xfe;
    }
}

codes! {
    /// Bits of a call's flags.
    FLAGS {
        /// Predict: the s g term.
        FLAG_GRAVITY = 1;
        /// Predict: the w f term.
        FLAG_FORCE = 2;
        /// Projection: first of its family this substep (λ = 0 before).
        FLAG_FIRST = 4;
        /// Distance: one-sided (|x1 − x0| ≤ rest).
        FLAG_TETHER = 8;
        /// Projection: nothing reads this λ later (not stored).
        FLAG_UNREAD = 16;
        /// Guard: the orientation test.
        FLAG_ORIENTATION = 32;
        /// Guard: the measure-ratio test.
        FLAG_RATIO = 64;
        /// Material: the Neo-Hookean law (else StVK).
        FLAG_NEO_HOOKEAN = 128;
        /// Guard: a material family.
        FLAG_MATERIAL = 256;
        /// Predict: every dynamic particle's gravity scale is 1.
        FLAG_UNIT_SCALE = 512;
        /// Contact, friction, residual: a moving hyperplane (motion.wgsl).
        FLAG_MOVING = 1024;
        /// A moving hyperplane whose motion rotates (its carry has Ā).
        FLAG_ROTATES = 2048;
        /// Projection: the update that carries the primal residual
        /// (primal.wgsl); predict: its warm start x += Σ d.
        FLAG_PRIMAL = 4096;
        /// Contact, friction: a simplex-mesh family (mesh_contact.wgsl).
        FLAG_MESH = 8192;
    }
}

codes! {
    /// The records a per-particle call loads and stores.
    IOS {
        IO_LOAD_X = 1;
        IO_LOAD_V = 2;
        IO_LOAD_P = 4;
        IO_STORE_X = 8;
        IO_STORE_V = 16;
        IO_STORE_P = 32;
    }
}

codes! {
    /// How residual.wgsl measures a family (`Call.kind`).
    RESIDUALS {
        RESIDUAL_DISTANCE = 0;
        RESIDUAL_SIMPLEX = 1;
        RESIDUAL_ORIENTED = 2;
        RESIDUAL_CONTACT = 3;
        RESIDUAL_TETHER = 4;
        RESIDUAL_MATERIAL = 5;
        RESIDUAL_EXPRESSION = 6;
        /// A simplex-mesh contact family (mesh_contact.wgsl).
        RESIDUAL_MESH = 7;
    }
}

codes! {
    /// The coupled step's element codes (coupled.wgsl).
    ELEMENTS {
        ELEMENT_DISTANCE = 0;
        ELEMENT_TETHER = 1;
        ELEMENT_SIMPLEX = 2;
        ELEMENT_ORIENTED = 3;
        ELEMENT_BALL = 4;
        ELEMENT_LAG = 5;
        ELEMENT_MATERIAL = 6;
        ELEMENT_EXPRESSION = 7;
    }
}

/// Every table, in header order.
pub const ALL: [&[(&str, u32)]; 5] = [OPS, FLAGS, IOS, RESIDUALS, ELEMENTS];

/// The residual code of a family kind.
pub fn residual_code(kind: &FamilyKind) -> u32 {
    match kind {
        FamilyKind::Distance => RESIDUAL_DISTANCE,
        FamilyKind::SimplexMeasure { .. } => RESIDUAL_SIMPLEX,
        FamilyKind::OrientedMeasure => RESIDUAL_ORIENTED,
        FamilyKind::HyperplaneContact { .. } => RESIDUAL_CONTACT,
        FamilyKind::MeshContact { .. } => RESIDUAL_MESH,
        FamilyKind::Tether => RESIDUAL_TETHER,
        FamilyKind::Material { .. } => RESIDUAL_MATERIAL,
        FamilyKind::Expression(_) => RESIDUAL_EXPRESSION,
    }
}

/// The coupled step's element code of a constraint family's elements;
/// `None` for hyperplane contact, which the coupled step treats as an
/// obstacle barrier, never as an element. Material and expression
/// elements are dense blocks (coupled_material.wgsl).
pub fn element_code(kind: &FamilyKind) -> Option<u32> {
    match kind {
        FamilyKind::Distance => Some(ELEMENT_DISTANCE),
        FamilyKind::Tether => Some(ELEMENT_TETHER),
        FamilyKind::SimplexMeasure { .. } => Some(ELEMENT_SIMPLEX),
        FamilyKind::OrientedMeasure => Some(ELEMENT_ORIENTED),
        FamilyKind::Material { .. } => Some(ELEMENT_MATERIAL),
        FamilyKind::Expression(_) => Some(ELEMENT_EXPRESSION),
        FamilyKind::HyperplaneContact { .. } | FamilyKind::MeshContact { .. } => None,
    }
}

/// The header lines of every table: `const NAME: u32 = VALUEu;`.
pub fn wgsl_header() -> String {
    ALL.iter()
        .flat_map(|table| table.iter())
        .map(|(name, value)| format!("const {name}: u32 = {value}u;\n"))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_and_values_are_distinct_within_a_table() {
        for table in ALL {
            for (i, (name, value)) in table.iter().enumerate() {
                for (other, other_value) in &table[..i] {
                    assert_ne!(name, other);
                    assert_ne!(value, other_value, "{name} and {other} share a value");
                }
            }
        }
    }
}
