//! The element list of the coupled step and each particle's gather list,
//! built once per pair set and shared by both backends (the GPU uploads
//! it as is).
//!
//! ```text
//! element e   members particles[e·A .. e·A + arity_e]  (A = arity_max ≥ 2, rest padded with 0)
//! slot        e·A + j: member j of element e (its gradient / product values)
//! gather      particle k's slots are entries[offsets[k] .. offsets[k + 1]], ascending
//!             (counting sort by particle over the slots in order)
//! ```
//! Each element writes only its own slots and each particle reads only its
//! own list: a gather needs no atomics, and its order — element order, then
//! the member within the element — is the same everywhere.

/// Members of every element and the per-particle gather lists.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ElementLists {
    /// Members, `arity_max` slots per element.
    pub particles: Vec<u32>,
    /// Members per element.
    pub arity: Vec<u32>,
    /// Largest arity (≥ 2).
    pub arity_max: usize,
    /// Particle k's slots are `entries[offsets[k]..offsets[k + 1]]`.
    pub offsets: Vec<u32>,
    /// Slots `e · arity_max + j`, per particle in ascending order.
    pub entries: Vec<u32>,
}

impl ElementLists {
    /// Empties the list for elements of at most `arity_max` (≥ 2) members.
    pub fn clear(&mut self, arity_max: usize) {
        self.arity_max = arity_max.max(2);
        self.particles.clear();
        self.arity.clear();
    }

    /// Number of elements.
    pub fn len(&self) -> usize {
        self.arity.len()
    }

    /// True with no element.
    pub fn is_empty(&self) -> bool {
        self.arity.is_empty()
    }

    /// Appends an element of `members`.
    pub fn push(&mut self, members: &[u32]) {
        self.arity.push(members.len() as u32);
        self.particles.extend_from_slice(members);
        self.particles
            .extend(std::iter::repeat_n(0, self.arity_max - members.len()));
    }

    /// The members of element e.
    pub fn members(&self, e: usize) -> &[u32] {
        let start = e * self.arity_max;
        &self.particles[start..start + self.arity[e] as usize]
    }

    /// Builds the gather lists of `particle_count` particles.
    pub fn build_gather(&mut self, particle_count: usize) {
        let width = self.arity_max;
        self.offsets.clear();
        self.offsets.resize(particle_count + 1, 0);
        for e in 0..self.len() {
            for j in 0..self.arity[e] as usize {
                self.offsets[self.particles[e * width + j] as usize + 1] += 1;
            }
        }
        for k in 0..particle_count {
            self.offsets[k + 1] += self.offsets[k];
        }
        self.entries.clear();
        self.entries
            .resize(self.offsets[particle_count] as usize, 0);
        let mut fill = self.offsets[..particle_count].to_vec();
        for e in 0..self.len() {
            for j in 0..self.arity[e] as usize {
                let k = self.particles[e * width + j] as usize;
                self.entries[fill[k] as usize] = (e * width + j) as u32;
                fill[k] += 1;
            }
        }
    }

    /// Particle k's slots.
    pub fn slots_of(&self, k: usize) -> &[u32] {
        &self.entries[self.offsets[k] as usize..self.offsets[k + 1] as usize]
    }
}
