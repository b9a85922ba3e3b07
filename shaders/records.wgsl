// Particle-record accessors when a record is VEC > 1 vec4 words (DIM ≥ 4;
// prelude.wgsl describes the layout; record4.wgsl is the one-word case).

alias Record = array<vec4<real>, VEC>;

fn load_x(i: u32) -> Record {
    var r: Record;
    for (var k = 0u; k < VEC; k++) {
        r[k] = x[VEC * particle(i) + k];
    }
    return r;
}

fn store_x(i: u32, r: Record) {
    for (var k = 0u; k < VEC; k++) {
        x[VEC * particle(i) + k] = r[k];
    }
}

fn load_v(i: u32) -> Record {
    var r: Record;
    for (var k = 0u; k < VEC; k++) {
        r[k] = v[VEC * particle(i) + k];
    }
    return r;
}

fn store_v(i: u32, r: Record) {
    for (var k = 0u; k < VEC; k++) {
        v[VEC * particle(i) + k] = r[k];
    }
}

fn load_p(i: u32) -> Record {
    var r: Record;
    for (var k = 0u; k < VEC; k++) {
        r[k] = p[VEC * particle(i) + k];
    }
    return r;
}

fn store_p(i: u32, r: Record) {
    for (var k = 0u; k < VEC; k++) {
        p[VEC * particle(i) + k] = r[k];
    }
}

fn load_force(i: u32) -> Record {
    var r: Record;
    for (var k = 0u; k < VEC; k++) {
        r[k] = force[VEC * particle(i) + k];
    }
    return r;
}

fn lane(r: ptr<function, Record>, a: u32) -> real {
    return (*r)[a / 4u][a % 4u];
}

fn set_lane(r: ptr<function, Record>, a: u32, value: real) {
    (*r)[a / 4u][a % 4u] = value;
}

fn inverse_mass_of(r: ptr<function, Record>) -> real {
    return (*r)[VEC - 1u].w;
}

fn set_last_lane(r: ptr<function, Record>, value: real) {
    (*r)[VEC - 1u].w = value;
}

// vec4 word c of the record (c < VEC), as stored in a buffer.
fn word(r: ptr<function, Record>, c: u32) -> vec4<real> {
    return (*r)[c];
}

fn set_word(r: ptr<function, Record>, c: u32, value: vec4<real>) {
    (*r)[c] = value;
}
