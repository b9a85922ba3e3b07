//! Drawing simplex meshes (`simplex_mesh` obstacles) where their
//! prescribed motion has them at the snapshot's time.
//!
//! ```text
//! vertex      x = M(t) v  (hyperpbd_core::motion::rigid_at), then the view's
//!             projection, as a particle's centre
//! segment     a line
//! k ≥ 2       every triangle face of the simplex, filled (translucent) and
//!             outlined
//! order       drawn after the hyperplanes and before the edges and
//!             particles; in perspective the faces far to near (painter's
//!             algorithm, ties in index order)
//! ```

use crate::color::{MESH_EDGE, MESH_FILL, fog};
use crate::framing::{Camera, Projected};
use hyperpbd_core::motion::{Motion, rigid_at};
use hyperpbd_core::{Obstacle, Scene};
use tiny_skia::{FillRule, Paint, PathBuilder, Pixmap, Stroke, Transform};

/// A mesh as drawn: its authored vertices, simplices and motion.
#[derive(Debug, Clone)]
pub(crate) struct Mesh {
    vertices: Vec<Vec<f64>>,
    simplices: Vec<Vec<usize>>,
    motion: Vec<Motion>,
}

/// The simplex meshes of `scene`, in obstacle order.
pub(crate) fn meshes(scene: &Scene) -> Vec<Mesh> {
    scene
        .obstacles
        .iter()
        .filter_map(|o| match o {
            Obstacle::SimplexMesh {
                vertices,
                simplices,
                motion,
                ..
            } => Some(Mesh {
                vertices: vertices.clone(),
                simplices: simplices.clone(),
                motion: motion.clone(),
            }),
            Obstacle::Hyperplane { .. } => None,
        })
        .collect()
}

fn paint(c: [u8; 3], alpha: u8) -> Paint<'static> {
    let mut p = Paint::default();
    p.set_color_rgba8(c[0], c[1], c[2], alpha);
    p.anti_alias = true;
    p
}

/// Draws `meshes` at time `time` (module docs).
pub(crate) fn draw_meshes(
    meshes: &[Mesh],
    camera: &Camera,
    (pixmap, time, unit): (&mut Pixmap, f64, f64),
) {
    let dim = camera.view.dim;
    let mut y = vec![0.0; dim];
    // Every face (or segment) as its projected corners.
    let mut faces: Vec<Vec<Projected>> = Vec::new();
    for mesh in meshes {
        let placed = rigid_at(&mesh.motion, dim, time);
        let points: Vec<Projected> = (mesh.vertices.iter())
            .map(|v| {
                camera
                    .view
                    .centred(&placed.apply(v), &camera.centre, time, &mut y);
                camera.project(&y)
            })
            .collect();
        for simplex in &mesh.simplices {
            let m = simplex.len();
            if m == 2 {
                faces.push(vec![points[simplex[0]], points[simplex[1]]]);
                continue;
            }
            for a in 0..m {
                for b in a + 1..m {
                    for c in b + 1..m {
                        let corners = [simplex[a], simplex[b], simplex[c]];
                        faces.push(corners.iter().map(|&k| points[k]).collect());
                    }
                }
            }
        }
    }
    if camera.view.is_perspective() {
        let depth = |f: &Vec<Projected>| f.iter().map(|p| p.distance).sum::<f64>() / f.len() as f64;
        faces.sort_by(|a, b| depth(b).total_cmp(&depth(a)));
    }
    let line = Stroke {
        width: (0.6 * unit) as f32,
        ..Stroke::default()
    };
    for face in faces {
        let shade = face.iter().map(|p| p.fog).sum::<f64>() / face.len() as f64;
        let mut pb = PathBuilder::new();
        pb.move_to(face[0].x as f32, face[0].y as f32);
        for p in &face[1..] {
            pb.line_to(p.x as f32, p.y as f32);
        }
        if face.len() > 2 {
            pb.close();
        }
        let Some(path) = pb.finish() else {
            continue;
        };
        let fill = fog([MESH_FILL[0], MESH_FILL[1], MESH_FILL[2]], shade);
        let edge = fog([MESH_EDGE[0], MESH_EDGE[1], MESH_EDGE[2]], shade);
        if face.len() > 2 {
            let p = paint(fill, MESH_FILL[3]);
            pixmap.fill_path(&path, &p, FillRule::Winding, Transform::identity(), None);
        }
        pixmap.stroke_path(
            &path,
            &paint(edge, MESH_EDGE[3]),
            &line,
            Transform::identity(),
            None,
        );
    }
}
