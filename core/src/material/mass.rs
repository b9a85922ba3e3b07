//! Lumped (diagonal) mass from density: each element's mass ρ·V_0 split
//! equally over its k + 1 vertices, V_0 the rest k-measure (length for
//! curves, area for membranes and triangles, volume, …).
//!
//! ```text
//! m_e   = ρ V_0(e)                      element mass
//! m_i  += m_e / (k + 1)                 for each vertex i of e (elements, then vertices, in order)
//! element total = Σ_e m_e               (e ascending)
//! vertex total  = Σ_i m_i               (i ascending)
//! ```
//! The two totals are equal up to rounding and are reported independently
//! (a check on the accumulation, not an assumption).

use super::{MaterialError, RestShapes};

/// Per-particle lumped masses of one family and its two totals.
#[derive(Debug, Clone, PartialEq)]
pub struct LumpedMass {
    /// Mass per particle (0 for particles in no element).
    pub masses: Vec<f64>,
    /// Σ_e ρ V_0(e).
    pub element_total: f64,
    /// Σ_i `masses[i]`.
    pub vertex_total: f64,
}

/// Lumped masses of `particle_count` particles from `elements` (whose rest
/// data is `rest`) at density `density`.
pub fn lump_masses(
    particle_count: usize,
    elements: &[Vec<usize>],
    rest: &RestShapes,
    density: f64,
) -> Result<LumpedMass, MaterialError> {
    if !(density.is_finite() && density > 0.0) {
        return Err(MaterialError::Density { value: density });
    }
    if elements.len() != rest.len() {
        return Err(MaterialError::ElementCount {
            elements: elements.len(),
            rest: rest.len(),
        });
    }
    let mut masses = vec![0.0; particle_count];
    let mut element_total = 0.0;
    for (e, (element, &measure)) in elements.iter().zip(rest.measures()).enumerate() {
        let mass = density * measure;
        element_total += mass;
        let share = mass / element.len() as f64;
        for &i in element {
            let Some(m) = masses.get_mut(i) else {
                return Err(MaterialError::IndexOutOfRange {
                    element: e,
                    index: i,
                    count: particle_count,
                });
            };
            *m += share;
        }
    }
    let mut vertex_total = 0.0;
    for m in &masses {
        vertex_total += m;
    }
    Ok(LumpedMass {
        masses,
        element_total,
        vertex_total,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unit_square_of_two_triangles() {
        let square = [0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0, 1.0];
        let elements = vec![vec![0, 1, 2], vec![0, 2, 3]];
        let rest = RestShapes::compile(2, &elements, &square).expect("valid");
        let lumped = lump_masses(5, &elements, &rest, 3.0).expect("valid");
        // Each triangle: 3 · ½ = 1.5, a third to each vertex.
        let expected = [1.0, 0.5, 1.0, 0.5, 0.0];
        for (m, e) in lumped.masses.iter().zip(expected) {
            approx::assert_relative_eq!(*m, e, max_relative = 4.0 * f64::EPSILON);
        }
        approx::assert_relative_eq!(lumped.element_total, 3.0, max_relative = 4.0 * f64::EPSILON);
        approx::assert_relative_eq!(lumped.vertex_total, 3.0, max_relative = 4.0 * f64::EPSILON);
        for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert!(matches!(
                lump_masses(5, &elements, &rest, bad),
                Err(MaterialError::Density { .. })
            ));
        }
        assert!(matches!(
            lump_masses(3, &elements, &rest, 1.0),
            Err(MaterialError::IndexOutOfRange {
                element: 1,
                index: 3,
                count: 3
            })
        ));
        assert!(matches!(
            lump_masses(5, &elements[..1], &rest, 1.0),
            Err(MaterialError::ElementCount {
                elements: 1,
                rest: 2
            })
        ));
    }
}
