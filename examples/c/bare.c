/*
 * The bare-metal C ABI (sph-ffi/bare/include/sph_bare.h) as a firmware uses
 * it: one static SphBare, a parameter struct, no allocator. Built here for
 * the host; on a Cortex-M the same code links target/thumbv7em-none-eabihf/
 * release/libsph_bare.a (`cargo build -p sph-ffi-bare --target
 * thumbv7em-none-eabihf --release`).
 *
 * Prints the error against the exact Couette series at four output times
 * and fails unless it falls below 1 % of U and keeps falling.
 */
#include <stdio.h>

#include "sph_bare.h"

static SphBare store; /* about 24 KB, placed by the linker */

int main(void) {
    SphBareCouette p = {
        .particles_across = 16,
        .gap = 1e-3,
        .wall_speed = 1.25e-5f,
        .nu = 1e-6f,
        .rho0 = 1000.0f,
        .sound_speed = 1.25e-4f,
        .beta = 1.3f,
        .dt_factor = 0.7,
    };
    SphBareStatus s = sph_bare_init(&store, &p);
    if (s != SPH_BARE_STATUS_OK) {
        printf("init failed: status %d\n", (int)s);
        return 1;
    }
    const double times[4] = {0.02, 0.05, 0.1, 0.2};
    double last = 1.0;
    for (int k = 0; k < 4; k++) {
        s = sph_bare_advance_to(&store, times[k]);
        if (s != SPH_BARE_STATUS_OK) {
            printf("advance failed: status %d\n", (int)s);
            return 1;
        }
        double linf = sph_bare_linf(&store);
        printf("t = %.2f s, %llu steps, L-inf error %.0f ppm of U\n", sph_bare_time(&store),
               (unsigned long long)sph_bare_steps(&store), linf * 1e6);
        if (k > 0 && !(linf < last)) {
            return 1;
        }
        last = linf;
    }
    /* A bad parameter is a status, not a crash. */
    p.beta = 5.0f;
    s = sph_bare_init(&store, &p);
    printf("beta = 5: status %d (invalid parameter is %d)\n", (int)s, (int)SPH_BARE_STATUS_INVALID_PARAMETER);
    return (last < 0.01 && s == SPH_BARE_STATUS_INVALID_PARAMETER) ? 0 : 1;
}
