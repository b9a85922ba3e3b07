// Stand-ins for mesh_contact.wgsl in a step module whose plan has no
// simplex-mesh family (no call has FLAG_MESH or RESIDUAL_MESH, so none of
// these runs; should one, it fails the step or reads as violated without
// bound). The walk, the closest point and the mesh bindings are composed
// only into the modules of plans with meshes (gpu/src/xpbd/mesh.rs).

fn mesh_contact_particle(i: u32, rx: ptr<function, Record>, rv: ptr<function, Record>, rp: ptr<function, Record>) {
    fail(i);
}

fn mesh_friction_particle(i: u32, rx: ptr<function, Record>, rv: ptr<function, Record>, rp: ptr<function, Record>) {
    fail(i);
}

fn mesh_violation(s: u32, p: ptr<function, array<real, DIM>>) -> real {
    return infinity();
}
