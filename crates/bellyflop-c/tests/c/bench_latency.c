/* Latency of the C API, measured from C: the paper's case solved cold, and
 * bf_replan over the re-plan sequence of `bellyflop sim` (the states and
 * times written by examples/sim_replans.rs, on guidance's planning
 * problem). examples/bench_latency.rs makes the same engine calls from
 * Rust on the same inputs; bench_latency.sh runs both, alternately, and
 * compares them. `make bench` here runs it all.
 *
 * Usage: bench_latency REPLANS_TXT PLANNING_TOML COLD_RUNS ROUNDS
 *
 * Prints, one record a line:
 *   cold <ms>                 each timed bf_solve of the paper's case
 *                             (the same solver, after one untimed solve)
 *   replan <round> <k> <ms>   each timed bf_replan
 *   answer <k> <status> <iterations> <adopted> <tf bits> <mf bits>
 *                             each re-plan's answer, from the first round
 *                             (the Rust bench must give the same bits) */
#define _POSIX_C_SOURCE 199309L
#include "bellyflop.h"

#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define MAX_STATES 256

static double now_ms(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

static uint64_t bits(double x) {
    uint64_t b;
    memcpy(&b, &x, sizeof b);
    return b;
}

#define TRY(call)                                                                      \
    do {                                                                               \
        bf_error e_ = (call);                                                          \
        if (e_ != BF_ERROR_OK) {                                                       \
            fprintf(stderr, "%s: %s: %s\n", #call, bf_error_str(e_), bf_last_error()); \
            exit(1);                                                                   \
        }                                                                              \
    } while (0)

static bf_solution solution_for(bf_solver *s) {
    size_t n = 0;
    bf_solution sol;
    TRY(bf_solver_node_count(s, &n));
    memset(&sol, 0, sizeof sol);
    sol.nodes = (bf_node *)calloc(n, sizeof(bf_node));
    sol.node_capacity = n;
    if (!sol.nodes) exit(1);
    return sol;
}

/* `runs` timed cold solves of the paper's case, after one untimed one. */
static void cold_solves(int runs) {
    bf_problem *p = NULL;
    bf_solver *s = NULL;
    bf_settings settings = bf_settings_default();
    TRY(bf_problem_paper(&p));
    TRY(bf_solver_new(p, &settings, &s));
    bf_solution sol = solution_for(s);
    TRY(bf_solve(s, &sol));
    for (int i = 0; i < runs; i++) {
        double t0 = now_ms();
        bf_error e = bf_solve(s, &sol);
        double t1 = now_ms();
        if (e != BF_ERROR_OK || sol.status != BF_STATUS_SOLVED) {
            fprintf(stderr, "cold solve: %s %s\n", bf_error_str(e), bf_status_str(sol.status));
            exit(1);
        }
        printf("cold %.6f\n", t1 - t0);
    }
    free(sol.nodes);
    bf_solver_free(s);
    bf_problem_free(p);
}

int main(int argc, char **argv) {
    if (argc != 5) {
        fprintf(stderr, "usage: %s REPLANS_TXT PLANNING_TOML COLD_RUNS ROUNDS\n", argv[0]);
        return 2;
    }
    static double t[MAX_STATES];
    static bf_state x[MAX_STATES];
    int n = 0;
    FILE *f = fopen(argv[1], "r");
    if (!f) {
        perror(argv[1]);
        return 1;
    }
    while (n < MAX_STATES &&
           fscanf(f, "%lf %lf %lf %lf %lf %lf %lf %lf %lf", &t[n], &x[n].x_m, &x[n].z_m,
                  &x[n].vx_mps, &x[n].vz_mps, &x[n].theta_rad, &x[n].pitch_rate_radps,
                  &x[n].mass_kg, &x[n].gimbal_rad) == 9) {
        n++;
    }
    fclose(f);
    if (n < 2) {
        fprintf(stderr, "%s: fewer than 2 states\n", argv[1]);
        return 1;
    }
    int cold_runs = atoi(argv[3]), rounds = atoi(argv[4]);
    cold_solves(cold_runs);

    bf_problem *planning = NULL;
    bf_settings settings = bf_settings_default();
    TRY(bf_problem_from_file(argv[2], &planning));
    TRY(bf_problem_set_initial_state(planning, &x[0]));
    for (int r = 0; r < rounds; r++) {
        /* Setup, untimed: the solver and its first plan. */
        bf_solver *s = NULL;
        TRY(bf_solver_new(planning, &settings, &s));
        bf_solution sol = solution_for(s);
        TRY(bf_solve(s, &sol));
        for (int k = 1; k < n; k++) {
            double t0 = now_ms();
            bf_error e = bf_replan(s, &x[k], t[k], &sol);
            double t1 = now_ms();
            TRY(e);
            printf("replan %d %d %.6f\n", r, k, t1 - t0);
            if (r == 0) {
                printf("answer %d %s %u %d 0x%016" PRIx64 " 0x%016" PRIx64 "\n", k,
                       bf_status_str(sol.status), sol.iterations, sol.adopted, bits(sol.tf_s),
                       bits(sol.final_mass_kg));
            }
        }
        free(sol.nodes);
        bf_solver_free(s);
    }
    bf_problem_free(planning);
    return 0;
}
