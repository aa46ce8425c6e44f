/*
 * Plane Couette flow through sph's C ABI (sph-ffi/include/sph.h), checked
 * against the exact series computed here, in C.
 *
 *   couette [RESOLUTION [T_END [CSV]]]   defaults: 20 particles across, 0.2 s
 *
 * With CSV, the final y and u of every particle go there (`y,vx`, in
 * particle id order, 17 digits).
 *
 * The run is `sph couette`'s (summation density, the Morris viscosity, plates
 * at y = -L and y = L), configured by the text of its configuration file.
 * The program prints the error the library reports at each output time (the
 * figures of `sph couette` at these settings) and the error of the
 * velocities it reads back against its own series, and fails if the two
 * disagree.
 *
 * Build (from the repository root, after `cargo build -p sph-ffi`):
 *   cc -std=c99 -O2 examples/c/couette.c -Isph-ffi/include \
 *      target/debug/libsph_ffi.a -lpthread -ldl -lm -o couette
 * `cargo xtask c-abi` builds and runs it, and compares with `sph couette`.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "sph.h"

/* The default flow of `sph couette` (docs/physics.md 6.a): plates at
 * y = -H/2 (at rest) and y = H/2 (moving at U from t = 0), kinematic
 * viscosity NU. */
#define H 1e-3
#define U 1.25e-5
#define NU 1e-6
#define PI 3.14159265358979323846

/* With y measured from the lower plate,
 * u(y, t) = U y / H + sum_n 2 U (-1)^n / (n pi) sin(n pi y / H) exp(-n^2 pi^2 nu t / H^2),
 * summed until the terms fall below 1e-17 U. */
static double exact_u(double y, double t) {
    double u = U * y / H;
    for (int n = 1; n < 100000; n++) {
        double decay = exp(-(double)n * n * PI * PI * NU * t / (H * H));
        double term = 2.0 * U / (n * PI) * decay;
        if (term < 1e-17 * U) {
            break;
        }
        u += (n % 2 ? -term : term) * sin(n * PI * y / H);
    }
    return u;
}

static int check(SphSimulation *sim, SphStatus status, const char *what) {
    if (status != SPH_STATUS_OK) {
        fprintf(stderr, "couette: %s failed (status %d): %s\n", what, (int)status,
                sim ? sph_simulation_error(sim) : "");
        return 1;
    }
    return 0;
}

int main(int argc, char **argv) {
    int resolution = argc > 1 ? atoi(argv[1]) : 20;
    double t_end = argc > 2 ? atof(argv[2]) : 0.2;
    char scene[512];
    snprintf(scene, sizeof scene,
             "particles_across = %d\n"
             "t_end = %.17g\n"
             "output_times = [%.17g, %.17g, %.17g]\n"
             "threads = 1\n",
             resolution, t_end, t_end / 4.0, t_end / 2.0, t_end);

    char message[512];
    SphSimulation *sim = NULL;
    if (sph_simulation_new_couette(scene, &sim, message, sizeof message) != SPH_STATUS_OK) {
        fprintf(stderr, "couette: cannot create the simulation: %s\n", message);
        return 1;
    }
    size_t n = sph_simulation_particles(sim);
    printf("sph %s: couette, %zu particles (%d across), dt = %.3e s, t_end = %g s\n", sph_version(), n,
           resolution, sph_simulation_dt(sim), sph_simulation_end_time(sim));

    /* Step in pieces, as a coupled solver would. */
    while (!sph_simulation_ended(sim)) {
        uint64_t taken = 0;
        if (check(sim, sph_simulation_advance(sim, 200, &taken), "advance")) {
            sph_simulation_free(sim);
            return 1;
        }
    }

    size_t outputs = sph_simulation_outputs(sim);
    SphDiagnostics d;
    for (size_t k = 0; k < outputs; k++) {
        if (check(sim, sph_simulation_diagnostics(sim, k, &d), "diagnostics")) {
            sph_simulation_free(sim);
            return 1;
        }
        printf("t = %.17g s  library, |v - v_exact|: linf %.17g  l2 %.17g\n", d.t, d.linf, d.l2);
    }

    /* The velocities, read back and compared with the series here. */
    size_t len_x = sph_simulation_field_len(sim, SPH_FIELD_POSITION);
    size_t len_v = sph_simulation_field_len(sim, SPH_FIELD_VELOCITY);
    double *x = malloc(len_x * sizeof *x);
    double *v = malloc(len_v * sizeof *v);
    if (!x || !v || check(sim, sph_simulation_read(sim, SPH_FIELD_POSITION, x, len_x), "read")
        || check(sim, sph_simulation_read(sim, SPH_FIELD_VELOCITY, v, len_v), "read")) {
        free(x);
        free(v);
        sph_simulation_free(sim);
        return 1;
    }
    size_t dim = sph_simulation_dim(sim);
    double t = sph_simulation_time(sim);
    unsigned long long steps = (unsigned long long)sph_simulation_steps(sim);
    /* Euclidean |v - v_exact| (the library's diagnostics), and u alone
     * (`sph couette`'s table), over U. */
    double worst = 0.0, worst_u = 0.0, sum_u2 = 0.0;
    FILE *csv = argc > 3 ? fopen(argv[3], "w") : NULL;
    if (csv) {
        fprintf(csv, "y,vx\n");
    }
    for (size_t i = 0; i < n; i++) {
        double y = x[i * dim + 1];
        double du = v[i * dim] - exact_u(y + 0.5 * H, t);
        double dv = v[i * dim + 1];
        double e = sqrt(du * du + dv * dv) / U;
        worst = e > worst ? e : worst;
        worst_u = fabs(du) / U > worst_u ? fabs(du) / U : worst_u;
        sum_u2 += (du / U) * (du / U);
        if (csv) {
            fprintf(csv, "%.17g,%.17g\n", y, v[i * dim]);
        }
    }
    if (csv) {
        fclose(csv);
    }
    free(x);
    free(v);

    /* A deliberate mistake is refused with a message, and changes nothing. */
    double one = 0.0;
    SphStatus refused = sph_simulation_write(sim, SPH_FIELD_PRESSURE, &one, 1);
    printf("writing 1 pressure value: status %d, \"%s\"\n", (int)refused, sph_simulation_error(sim));
    sph_simulation_free(sim);

    printf("final: t = %.17g s, %llu steps\n", t, steps);
    printf("library, |v - v_exact|:  linf %.17g\n", d.linf);
    printf("C series, |v - v_exact|: linf %.17g\n", worst);
    printf("C series, u alone:       linf_u %.17g  l2_u %.17g\n", worst_u, sqrt(sum_u2 / (double)n));
    double gap = fabs(worst - d.linf);
    if (refused != SPH_STATUS_CONFIG || !(gap <= 1e-9 * d.linf + 1e-15)) {
        fprintf(stderr, "couette: the two errors differ by %.3e\n", gap);
        return 1;
    }
    return 0;
}
