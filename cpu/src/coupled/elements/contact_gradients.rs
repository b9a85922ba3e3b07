//! The contact elements' gradients from the records (contact forces out,
//! `coupled/contacts.rs`).

use super::{Elements, Kind};

impl Elements {
    /// The contact elements' (ball barriers', pair friction's) gradients
    /// from the records: `each` receives (particle, ∇_k E_e), element by
    /// element, member by member.
    pub fn contact_gradients(&self, dim: usize, mut each: impl FnMut(usize, &[f64])) {
        let stride = self.record_len(dim);
        for (e, kind) in self.kinds.iter().enumerate() {
            match kind {
                Kind::Ball | Kind::Friction { .. } => {}
                Kind::Spring { .. } | Kind::Material { .. } | Kind::Expression { .. } => continue,
            }
            for (local, &k) in self.lists.members(e).iter().enumerate() {
                let at = e * stride + 3 + local * dim;
                each(k as usize, &self.records[at..at + dim]);
            }
        }
    }
}
