// Cholesky factor L of the symmetric n×n `a` into `l` (lower; strictly
// upper part 0; core::material::cholesky, the same operations in the same
// order); false when a pivot is not > 0 (or NaN).
//
// Written once for every square array a module factors: shader.rs
// (`cholesky_over`) composes it per array type, CHOLESKY_NAME and
// CHOLESKY_ARRAY replaced (material_cholesky over array<real, MAT>,
// primal_cholesky over array<real, SYS>).
fn CHOLESKY_NAME(a: ptr<function, CHOLESKY_ARRAY>, n: u32, l: ptr<function, CHOLESKY_ARRAY>) -> bool {
    for (var j = 0u; j < n; j++) {
        var d = (*a)[j * n + j];
        for (var m = 0u; m < j; m++) {
            d -= (*l)[j * n + m] * (*l)[j * n + m];
        }
        if (!(d > 0.0)) {
            return false;
        }
        let ljj = sqrt(d);
        (*l)[j * n + j] = ljj;
        for (var c = j + 1u; c < n; c++) {
            (*l)[j * n + c] = 0.0;
        }
        for (var i = j + 1u; i < n; i++) {
            var s = (*a)[i * n + j];
            for (var m = 0u; m < j; m++) {
                s -= (*l)[i * n + m] * (*l)[j * n + m];
            }
            (*l)[i * n + j] = s / ljj;
        }
    }
    return true;
}
