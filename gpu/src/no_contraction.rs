//! A SPIR-V word-stream pass: every floating-point arithmetic result gets
//! the `NoContraction` decoration, so no driver may fuse a·b + c into one
//! rounding or regroup a sum.
//!
//! ```text
//! module   = header (5 words) · instructions
//! instr    = word 0: (word count << 16) | opcode, then its operands
//! float op = OpFNegate OpFAdd OpFSub OpFMul OpFDiv OpFRem OpFMod
//!            OpVectorTimesScalar OpMatrixTimesScalar OpVectorTimesMatrix
//!            OpMatrixTimesVector OpMatrixTimesMatrix OpOuterProduct OpDot
//!            (result type, result id, operands: the id is word 2)
//! decorate = for each float-op result id r not yet decorated:
//!              OpDecorate r NoContraction      (3 words: 71 | 3 << 16, r, 42)
//!            inserted where the annotation section ends (before the first
//!            type, constant, variable or function instruction)
//! ```
//! These opcodes produce floating-point results only, so no type tracking
//! is needed. `fma` (GLSL.std.450 `Fma`) is an explicit fused operation and
//! stays as written; the project's shaders call no other float built-in that
//! a driver could expand into contractible arithmetic (they use `abs`,
//! `min`, `max`, `select`, `floor`, `sqrt`, `ldexp`, `log2` on f32, and
//! their own functions).

/// SPIR-V's magic number (word 0 of a module, in the module's endianness).
const MAGIC: u32 = 0x0723_0203;
/// `OpDecorate`.
const OP_DECORATE: u32 = 71;
/// Decoration `NoContraction`.
const NO_CONTRACTION: u32 = 42;

/// Opcodes whose result is floating-point arithmetic a driver could
/// contract (fuse into a multiply-add) or regroup.
pub const FLOAT_ARITHMETIC: [u32; 14] = [
    127, // OpFNegate
    129, // OpFAdd
    131, // OpFSub
    133, // OpFMul
    136, // OpFDiv
    140, // OpFRem
    141, // OpFMod
    142, // OpVectorTimesScalar
    143, // OpMatrixTimesScalar
    144, // OpVectorTimesMatrix
    145, // OpMatrixTimesVector
    146, // OpMatrixTimesMatrix
    147, // OpOuterProduct
    148, // OpDot
];

/// Opcodes of the sections before types: capabilities, extensions, memory
/// model, entry points, execution modes, debug names and annotations.
const PREAMBLE: [u32; 22] = [
    17,   // OpCapability
    10,   // OpExtension
    11,   // OpExtInstImport
    14,   // OpMemoryModel
    15,   // OpEntryPoint
    16,   // OpExecutionMode
    331,  // OpExecutionModeId
    7,    // OpString
    4,    // OpSourceExtension
    3,    // OpSource
    2,    // OpSourceContinued
    5,    // OpName
    6,    // OpMemberName
    330,  // OpModuleProcessed
    71,   // OpDecorate
    72,   // OpMemberDecorate
    73,   // OpDecorationGroup
    74,   // OpGroupDecorate
    75,   // OpGroupMemberDecorate
    332,  // OpDecorateId
    5632, // OpDecorateString
    5633, // OpMemberDecorateString
];

/// One instruction: its word offset, opcode and word count.
struct Instruction {
    at: usize,
    opcode: u32,
    count: usize,
}

/// The instructions of `words`, or why the stream is not a SPIR-V module.
fn instructions(words: &[u32]) -> Result<Vec<Instruction>, String> {
    if words.len() < 5 || words[0] != MAGIC {
        return Err("not a SPIR-V module (no header or wrong magic number)".into());
    }
    let mut out = Vec::new();
    let mut at = 5;
    while at < words.len() {
        let count = (words[at] >> 16) as usize;
        let opcode = words[at] & 0xffff;
        if count == 0 || at + count > words.len() {
            return Err(format!(
                "instruction at word {at} (opcode {opcode}) has word count {count}; \
                 the module has {} words",
                words.len()
            ));
        }
        out.push(Instruction { at, opcode, count });
        at += count;
    }
    Ok(out)
}

/// Result ids of the float arithmetic of `words`, in stream order.
fn float_results(words: &[u32], list: &[Instruction]) -> Result<Vec<u32>, String> {
    let mut ids = Vec::new();
    for i in list {
        if FLOAT_ARITHMETIC.contains(&i.opcode) {
            if i.count < 3 {
                return Err(format!(
                    "float instruction at word {} (opcode {}) has no result id",
                    i.at, i.opcode
                ));
            }
            ids.push(words[i.at + 2]);
        }
    }
    Ok(ids)
}

/// Ids that already carry `NoContraction`.
fn decorated(words: &[u32], list: &[Instruction]) -> std::collections::BTreeSet<u32> {
    list.iter()
        .filter(|i| i.opcode == OP_DECORATE && i.count >= 3 && words[i.at + 2] == NO_CONTRACTION)
        .map(|i| words[i.at + 1])
        .collect()
}

/// `words` with `OpDecorate %r NoContraction` for every float arithmetic
/// result `%r` that lacks it, inserted at the end of the annotation section.
///
/// # Errors
///
/// A message when `words` is not a well-formed SPIR-V instruction stream.
pub fn decorate(words: &[u32]) -> Result<Vec<u32>, String> {
    let list = instructions(words)?;
    let done = decorated(words, &list);
    let mut missing = float_results(words, &list)?;
    missing.retain(|id| !done.contains(id));
    missing.dedup();
    let insert = list
        .iter()
        .find(|i| !PREAMBLE.contains(&i.opcode))
        .map_or(words.len(), |i| i.at);
    let mut out = Vec::with_capacity(words.len() + 3 * missing.len());
    out.extend_from_slice(&words[..insert]);
    for id in missing {
        out.extend_from_slice(&[OP_DECORATE | (3 << 16), id, NO_CONTRACTION]);
    }
    out.extend_from_slice(&words[insert..]);
    Ok(out)
}

/// Float arithmetic result ids of `words` without `NoContraction` (empty
/// for a module [`decorate`] wrote), and how many float results it has.
///
/// # Errors
///
/// A message when `words` is not a well-formed SPIR-V instruction stream.
pub fn undecorated(words: &[u32]) -> Result<(Vec<u32>, usize), String> {
    let list = instructions(words)?;
    let done = decorated(words, &list);
    let all = float_results(words, &list)?;
    let total = all.len();
    Ok((
        all.into_iter().filter(|id| !done.contains(id)).collect(),
        total,
    ))
}

/// `words` without the `NoContraction` decoration of `id` (for tests that
/// prove a missing decoration is caught).
///
/// # Errors
///
/// A message when `words` is not a well-formed SPIR-V instruction stream.
pub fn strip_decoration(words: &[u32], id: u32) -> Result<Vec<u32>, String> {
    let list = instructions(words)?;
    let mut out = words[..5].to_vec();
    for i in &list {
        let is_it = i.opcode == OP_DECORATE
            && i.count >= 3
            && words[i.at + 1] == id
            && words[i.at + 2] == NO_CONTRACTION;
        if !is_it {
            out.extend_from_slice(&words[i.at..i.at + i.count]);
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A hand-made module: capability, memory model, a name, float type,
    /// then an OpFAdd (%5) and OpFMul (%6) and an integer add (%7).
    fn module() -> Vec<u32> {
        vec![
            MAGIC,
            0x0001_0300,
            0,
            8,
            0,
            17 | (2 << 16),
            1, // OpCapability Shader
            14 | (3 << 16),
            0,
            1, // OpMemoryModel
            5 | (3 << 16),
            5,
            0x0061, // OpName %5 "a"
            22 | (3 << 16),
            2,
            32, // OpTypeFloat %2 32
            129 | (5 << 16),
            2,
            5,
            3,
            4, // OpFAdd %2 %5 %3 %4
            133 | (5 << 16),
            2,
            6,
            5,
            5, // OpFMul %2 %6 %5 %5
            128 | (5 << 16),
            2,
            7,
            3,
            4, // OpIAdd (not float)
        ]
    }

    #[test]
    fn decorates_every_float_result_once_after_the_names() {
        let words = module();
        assert_eq!(undecorated(&words).unwrap(), (vec![5, 6], 2));
        let out = decorate(&words).unwrap();
        assert_eq!(out.len(), words.len() + 6);
        assert_eq!(
            &out[13..19],
            &[
                OP_DECORATE | (3 << 16),
                5,
                42,
                OP_DECORATE | (3 << 16),
                6,
                42
            ]
        );
        assert_eq!(undecorated(&out).unwrap(), (vec![], 2));
        assert_eq!(decorate(&out).unwrap(), out, "idempotent");
        let stripped = strip_decoration(&out, 6).unwrap();
        assert_eq!(undecorated(&stripped).unwrap(), (vec![6], 2));
    }

    #[test]
    fn malformed_streams_are_errors() {
        assert!(decorate(&[1, 2, 3]).is_err());
        let mut words = module();
        words.push(129 | (9 << 16));
        assert!(decorate(&words).is_err());
        let mut zero = module();
        zero.push(0);
        assert!(undecorated(&zero).is_err());
    }
}
