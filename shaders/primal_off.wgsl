// Stand-ins for primal.wgsl and primal_material.wgsl in a step module
// whose plan does not carry the primal residual (no call has FLAG_PRIMAL,
// so none of these runs; should one, it fails the step). The update's
// code, and the eigen-solver and frame Hessian its material step needs,
// are composed only into the modules of plans that use them
// (gpu/src/shader.rs `primal_source`): every XPBD pipeline of every other
// plan compiles without them.

fn warm_start_particle(i: u32, rx: ptr<function, Record>) {}

fn primal_contact_particle(i: u32, rx: ptr<function, Record>, rp: ptr<function, Record>) {
    fail(i);
}

fn primal_distance_element(t: u32) {
    fail(call.first + t);
}

fn primal_measure_element(t: u32, op: u32) {
    fail(call.first + t);
}
