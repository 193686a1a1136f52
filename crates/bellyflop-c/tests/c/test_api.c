/* The C API's test: links the static library, solves the paper's case and
 * checks t_f and m_f bit for bit against the Rust answer (given as the bits
 * of the doubles on the command line, from `examples/reference.rs`), runs
 * 200 bf_replan calls along a flown trajectory, and feeds bad input (NULL,
 * NaN, malformed TOML, a too-small buffer, out-of-range settings), each of
 * which must give its error code and no crash. Run by `make test` here,
 * which `scripts/test` calls (also under valgrind memcheck).
 *
 * Usage: test_api TF_BITS MF_BITS  (hex, e.g. 0x4027...) */
#include "bellyflop.h"

#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int passed = 0, failed = 0;

#define CHECK(cond, ...)                                                      \
    do {                                                                      \
        if (cond) {                                                           \
            passed++;                                                         \
        } else {                                                              \
            failed++;                                                         \
            fprintf(stderr, "FAIL %s:%d: %s: ", __FILE__, __LINE__, #cond);   \
            fprintf(stderr, __VA_ARGS__);                                     \
            fprintf(stderr, " (last error: %s)\n", bf_last_error());          \
        }                                                                     \
    } while (0)

/* `code` is `want`, and the last error mentions `needle`. */
#define CHECK_ERROR(call, want, needle)                                       \
    do {                                                                      \
        bf_error got_ = (call);                                               \
        CHECK(got_ == (want), "%s returned %s, expected %s", #call,           \
              bf_error_str(got_), bf_error_str(want));                        \
        CHECK(strstr(bf_last_error(), (needle)) != NULL,                      \
              "%s: message lacks \"%s\"", #call, (needle));                   \
    } while (0)

static uint64_t bits(double x) {
    uint64_t b;
    memcpy(&b, &x, sizeof b);
    return b;
}

/* A solution over a freshly allocated node buffer of `capacity` nodes. */
static bf_solution solution_with(size_t capacity) {
    bf_solution s;
    memset(&s, 0, sizeof s);
    s.nodes = (bf_node *)calloc(capacity ? capacity : 1, sizeof(bf_node));
    s.node_capacity = capacity;
    return s;
}

/* The paper's case cold, bit for bit as the Rust planner solves it. */
static void cold_solve_matches_rust(bf_solver *solver, size_t n_nodes, uint64_t tf_bits,
                                    uint64_t mf_bits) {
    bf_solution sol = solution_with(n_nodes);
    CHECK(bf_solve(solver, &sol) == BF_ERROR_OK, "bf_solve");
    CHECK(sol.status == BF_STATUS_SOLVED, "status %s", bf_status_str(sol.status));
    CHECK(sol.adopted, "a solved cold solve becomes the plan");
    CHECK(sol.node_count == n_nodes, "node_count %zu", sol.node_count);
    CHECK(bits(sol.tf_s) == tf_bits, "t_f %.17g (0x%016" PRIx64 ") vs Rust 0x%016" PRIx64,
          sol.tf_s, bits(sol.tf_s), tf_bits);
    CHECK(bits(sol.final_mass_kg) == mf_bits,
          "m_f %.17g (0x%016" PRIx64 ") vs Rust 0x%016" PRIx64, sol.final_mass_kg,
          bits(sol.final_mass_kg), mf_bits);
    /* The nodes are the trajectory: from t = 0 to t_f, ending at m_f. */
    CHECK(sol.nodes[0].t_s == 0.0, "first node at %g s", sol.nodes[0].t_s);
    CHECK(sol.nodes[n_nodes - 1].t_s == sol.tf_s, "last node at %g s", sol.nodes[n_nodes - 1].t_s);
    CHECK(sol.nodes[n_nodes - 1].state.mass_kg == sol.final_mass_kg, "last node's mass");
    CHECK(sol.iterations > 0, "iterations %u", sol.iterations);
    free(sol.nodes);
}

/* 200 re-plans along the flown trajectory: the plant flies each new plan
 * exactly (the plan-following integrator) and the measurement carries a
 * small deterministic error (5 cm in x, 2 cm/s in Vz). Every call must run
 * and answer from the measured state; an adopted plan's final mass stays
 * within 100 kg of the cold solve's (Bellman: the plan's tail is nearly
 * optimal from a state near it). Before the final burn (the first half of
 * t_f) every re-plan must solve; on the final burn, with the thrust on its
 * limit and no margin in this plain problem (guidance plans with margins
 * and a gate), some cannot null the lateral error and keep the old plan,
 * which is what they must do. */
static void replans_along_a_flight(bf_solver *solver, size_t n_nodes) {
    bf_solution sol = solution_with(n_nodes);
    double start = 0.0;
    CHECK(bf_solve(solver, &sol) == BF_ERROR_OK, "bf_solve");
    const double tf0 = sol.tf_s, mf0 = sol.final_mass_kg;
    const int n_replans = 200;
    const double dt = 0.75 * tf0 / n_replans;
    int ok = 0, solved = 0, consistent = 0, early = 0, early_solved = 0, near = 0, adopted = 0;
    for (int k = 1; k <= n_replans; k++) {
        double t = k * dt, start_before = 0.0;
        bf_state x;
        if (bf_plan_state_at(solver, t, &x) != BF_ERROR_OK) {
            break;
        }
        x.x_m += 0.05 * sin(0.7 * k);
        x.vz_mps += 0.02 * cos(1.3 * k);
        bf_plan_start_s(solver, &start_before);
        bf_error e = bf_replan(solver, &x, t, &sol);
        bf_plan_start_s(solver, &start);
        if (getenv("BF_TEST_VERBOSE")) {
            printf("t=%.3f %s its=%u adopted=%d mf=%.3f\n", t, bf_status_str(sol.status),
                   sol.iterations, sol.adopted, sol.final_mass_kg);
        }
        if (e != BF_ERROR_OK) {
            continue;
        }
        ok++;
        solved += sol.status == BF_STATUS_SOLVED;
        early += t <= 0.5 * tf0;
        early_solved += t <= 0.5 * tf0 && sol.status == BF_STATUS_SOLVED;
        adopted += sol.adopted;
        near += sol.adopted && fabs(sol.final_mass_kg - mf0) < 100.0;
        /* From the measured state; the plan's start moves to the
         * measurement's time if and only if the answer is adopted, and only
         * a solved answer is. */
        consistent += sol.nodes[0].state.z_m == x.z_m && sol.nodes[0].state.mass_kg == x.mass_kg &&
                      sol.adopted == (sol.status == BF_STATUS_SOLVED) &&
                      (sol.adopted ? start == t : start == start_before);
    }
    CHECK(ok == n_replans, "%d of %d re-plans returned BF_ERROR_OK", ok, n_replans);
    CHECK(consistent == n_replans, "%d of %d re-plans consistent", consistent, n_replans);
    CHECK(early > 100 && early_solved == early, "%d of %d re-plans before the final burn solved",
          early_solved, early);
    CHECK(near == adopted, "%d of %d adopted plans within 100 kg of the cold m_f", near, adopted);
    printf("replans: %d of %d solved (%d of %d before the final burn) along %.3f s of flight\n",
           solved, n_replans, early_solved, early, n_replans * dt);
    free(sol.nodes);
}

static void null_pointers(bf_problem *paper, bf_solver *solver, size_t n_nodes) {
    bf_problem *p = NULL;
    bf_solver *s = NULL;
    bf_settings settings = bf_settings_default();
    bf_solution sol = solution_with(n_nodes);
    bf_state x;
    size_t n;
    bf_problem_initial_state(paper, &x);
    CHECK_ERROR(bf_problem_paper(NULL), BF_ERROR_NULL_POINTER, "out");
    CHECK_ERROR(bf_problem_from_toml_str(NULL, &p), BF_ERROR_NULL_POINTER, "toml");
    CHECK_ERROR(bf_problem_from_file(NULL, &p), BF_ERROR_NULL_POINTER, "path");
    CHECK_ERROR(bf_problem_set_initial_state(NULL, &x), BF_ERROR_NULL_POINTER, "problem");
    CHECK_ERROR(bf_problem_set_initial_state(paper, NULL), BF_ERROR_NULL_POINTER, "state");
    CHECK_ERROR(bf_problem_node_count(paper, NULL), BF_ERROR_NULL_POINTER, "out");
    CHECK_ERROR(bf_solver_new(NULL, &settings, &s), BF_ERROR_NULL_POINTER, "problem");
    CHECK_ERROR(bf_solver_new(paper, NULL, &s), BF_ERROR_NULL_POINTER, "settings");
    CHECK_ERROR(bf_solver_new(paper, &settings, NULL), BF_ERROR_NULL_POINTER, "out");
    CHECK_ERROR(bf_solver_node_count(NULL, &n), BF_ERROR_NULL_POINTER, "solver");
    CHECK_ERROR(bf_solve(NULL, &sol), BF_ERROR_NULL_POINTER, "solver");
    CHECK_ERROR(bf_solve(solver, NULL), BF_ERROR_NULL_POINTER, "solution");
    CHECK_ERROR(bf_replan(NULL, &x, 0.1, &sol), BF_ERROR_NULL_POINTER, "solver");
    CHECK_ERROR(bf_replan(solver, NULL, 0.1, &sol), BF_ERROR_NULL_POINTER, "measured_state");
    CHECK_ERROR(bf_replan(solver, &x, 0.1, NULL), BF_ERROR_NULL_POINTER, "solution");
    CHECK_ERROR(bf_plan_state_at(solver, 0.1, NULL), BF_ERROR_NULL_POINTER, "out");
    CHECK_ERROR(bf_plan_controls_at(solver, 0.1, NULL, NULL), BF_ERROR_NULL_POINTER,
                "thrust_per_mass_npkg");
    free(sol.nodes);
    sol.nodes = NULL;
    CHECK_ERROR(bf_solve(solver, &sol), BF_ERROR_NULL_POINTER, "solution.nodes");
    CHECK(p == NULL && s == NULL, "no object made on a failed call");
    bf_problem_free(NULL); /* ignored */
    bf_solver_free(NULL);
}

static void bad_numbers(bf_problem *paper, bf_solver *solver, size_t n_nodes) {
    bf_state x, before, after;
    bf_solution sol = solution_with(n_nodes);
    bf_settings settings = bf_settings_default();
    bf_solver *s = NULL;
    bf_problem_initial_state(paper, &before);
    x = before;
    x.z_m = NAN;
    CHECK_ERROR(bf_problem_set_initial_state(paper, &x), BF_ERROR_INVALID_INPUT, "initial.z_m = NaN");
    bf_problem_initial_state(paper, &after);
    CHECK(memcmp(&before, &after, sizeof before) == 0, "a refused state leaves the problem as it was");
    double t0 = 0.0;
    bf_plan_start_s(solver, &t0);
    x = before;
    x.mass_kg = -1.0;
    CHECK_ERROR(bf_replan(solver, &x, t0 + 0.1, &sol), BF_ERROR_INVALID_INPUT, "measured_state: initial.mass_kg = -1");
    CHECK_ERROR(bf_replan(solver, &before, NAN, &sol), BF_ERROR_INVALID_INPUT, "t_now_s = NaN");
    CHECK_ERROR(bf_replan(solver, &before, t0 - 1.0, &sol), BF_ERROR_INVALID_INPUT, "not before the current plan's start");
    CHECK_ERROR(bf_plan_state_at(solver, INFINITY, &x), BF_ERROR_INVALID_INPUT, "t_now_s = inf");
    settings.time_budget_s = NAN;
    CHECK_ERROR(bf_solver_new(paper, &settings, &s), BF_ERROR_INVALID_INPUT, "settings.time_budget_s = NaN");
    settings = bf_settings_default();
    settings.method = 7;
    CHECK_ERROR(bf_solver_new(paper, &settings, &s), BF_ERROR_INVALID_INPUT, "settings.method = 7");
    CHECK(s == NULL, "no solver from bad settings");
    free(sol.nodes);
}

static void bad_text_and_buffers(bf_solver *solver, size_t n_nodes) {
    bf_problem *p = NULL;
    bf_solver *s = NULL;
    bf_solution small = solution_with(n_nodes - 1);
    bf_state x;
    CHECK_ERROR(bf_problem_from_toml_str("[vehicle\ndry_mass_kg = ", &p), BF_ERROR_PARSE, "line 1");
    CHECK_ERROR(bf_problem_from_toml_str("[vehicle]\nbogus_field = 1\n", &p), BF_ERROR_PARSE, "bogus_field");
    CHECK_ERROR(bf_problem_from_toml_str("\xff\xfe", &p), BF_ERROR_NOT_UTF8, "toml is not UTF-8");
    CHECK_ERROR(bf_problem_from_file("/nonexistent/scenario.toml", &p), BF_ERROR_IO, "/nonexistent/scenario.toml");
    CHECK(p == NULL, "no problem from bad text");
    CHECK_ERROR(bf_solve(solver, &small), BF_ERROR_BUFFER_TOO_SMALL, "solution.node_capacity");
    double t0 = 0.0;
    bf_plan_start_s(solver, &t0);
    bf_plan_state_at(solver, t0 + 0.1, &x);
    CHECK_ERROR(bf_replan(solver, &x, t0 + 0.1, &small), BF_ERROR_BUFFER_TOO_SMALL, "node_capacity");
    CHECK(small.node_count == 0, "nothing written into a too-small buffer");
    /* A plan query before any plan. */
    bf_problem_paper(&p);
    bf_settings settings = bf_settings_default();
    bf_solver_new(p, &settings, &s);
    CHECK_ERROR(bf_plan_state_at(s, 0.0, &x), BF_ERROR_INVALID_INPUT, "no plan");
    bf_solver_free(s);
    bf_problem_free(p);
    free(small.nodes);
}

/* The budgets end a call with the best iterate and not_converged. */
/* The paper's scenario, written out (its [solver] tables are optional). */
static const char *const PAPER_TOML =
    "name = \"paper\"\n"
    "[vehicle]\n"
    "dry_mass_kg = 85000.0\n"
    "length_m = 50.0\n"
    "radius_m = 4.5\n"
    "cg_m = 20.0\n"
    "cp_m = 22.5\n"
    "max_thrust_n = 2210000.0\n"
    "min_thrust_n = 880000.0\n"
    "isp_s = 330.0\n"
    "max_gimbal_deg = 20.0\n"
    "max_gimbal_rate_degps = 20.0\n"
    "drag_coefficient_kgpm = 195.52\n"
    "[environment]\n"
    "g0_mps2 = 9.81\n"
    "wind_x_mps = 0.0\n"
    "[initial]\n"
    "x_m = 100.0\n"
    "z_m = 600.0\n"
    "vx_mps = 0.0\n"
    "vz_mps = -85.0\n"
    "theta_deg = 90.0\n"
    "pitch_rate_degps = 0.0\n"
    "mass_kg = 120000.0\n"
    "gimbal_deg = 0.0\n"
    "[terminal]\n"
    "x_m = 0.0\n"
    "z_m = 0.0\n"
    "vx_mps = 0.0\n"
    "vz_mps = 0.0\n"
    "theta_deg = 0.0\n"
    "pitch_rate_degps = 0.0\n"
    "[discretization]\n"
    "nodes = 20\n"
    "intervals = 1\n";

/* A smooth altitude trigger's limit: bound + slope * softplus(dz - h),
 * softplus of width 1 m (the library's problem::constraints). */
static double opened(double bound, double slope, double dz, double h) {
    double u = dz - h;
    return bound + slope * (fmax(u, 0.0) + log1p(exp(-fabs(u))));
}

/* Whether node `k` holds the pitch-rate, tilt (below 50 m) and final
 * descent (below 20 m) limits of `constraints_from_toml` to 1e-6 of each. */
static int holds_limits(const bf_node *node) {
    const double deg = acos(-1.0) / 180.0, rate = 20.0 * deg;
    const bf_state *y = &node->state;
    double tilt = opened(10.0 * deg, deg, y->z_m, 50.0);
    double lateral = opened(2.0, 1.0, y->z_m, 20.0);
    return fabs(y->pitch_rate_radps) <= rate * (1.0 + 1e-6) &&
           fabs(y->theta_rad) <= tilt * (1.0 + 1e-6) &&
           fabs(y->vx_mps) <= lateral * (1.0 + 1e-6);
}

/* Whether a node is inside the cone of half-angle atan(tan_gamma) about
 * the pad at the origin (1e-6 m of slack for rounding). */
static int inside_cone(const bf_node *node, double tan_gamma) {
    return fabs(node->state.x_m) <= tan_gamma * node->state.z_m + 1e-6;
}

/* The [constraints] table from TOML. The direct method holds every limit
 * at its nodes: with the pitch rate (a 20 deg/s limit, which the paper's
 * answer breaks), the tilt and the final descent, the cold solve and 20
 * re-plans along the plan are solved, adopted, and hold every limit at
 * every node; with an 11 deg cone, which the paper's answer leaves (it
 * keeps x in its KKT solve), the cold solve and re-plans likewise. */
static void constraints_from_toml(size_t n_nodes) {
    static const char *const LIMITS =
        "[constraints]\n"
        "max_pitch_rate_degps = 20.0\n"
        "max_tilt_deg = 10.0\n"
        "tilt_below_m = 50.0\n"
        "final_descent_m = 20.0\n"
        "final_descent_lateral_mps = 2.0\n";
    static const char *const CONE = "[constraints]\ncone_half_angle_deg = 11.0\n";
    char text[4096];
    bf_problem *p = NULL;
    bf_solver *s = NULL;
    bf_settings settings = bf_settings_default();
    bf_solution sol = solution_with(n_nodes);
    settings.method = BF_METHOD_DIRECT;
    snprintf(text, sizeof text, "%s%s", PAPER_TOML, LIMITS);
    CHECK(bf_problem_from_toml_str(text, &p) == BF_ERROR_OK, "the limits' TOML");
    CHECK(p && bf_solver_new(p, &settings, &s) == BF_ERROR_OK, "solver with limits");
    if (s) {
        int held = 0, replans = 0, solved = 0, solved_held = 0;
        CHECK(bf_solve(s, &sol) == BF_ERROR_OK && sol.status == BF_STATUS_SOLVED && sol.adopted,
              "cold solve with limits: %s", bf_status_str(sol.status));
        for (size_t k = 0; k < sol.node_count; k++) {
            held += holds_limits(&sol.nodes[k]);
        }
        CHECK(held == (int)n_nodes, "%d of %zu nodes hold the limits", held, n_nodes);
        const double tf = sol.tf_s;
        for (int k = 1; k <= 20; k++) {
            bf_state x;
            double t = 0.03 * k * tf;
            if (bf_plan_state_at(s, t, &x) != BF_ERROR_OK ||
                bf_replan(s, &x, t, &sol) != BF_ERROR_OK) {
                continue;
            }
            replans++;
            if (getenv("BF_TEST_VERBOSE")) {
                printf("limits: t=%.3f z=%.1f %s its=%u\n", t, x.z_m, bf_status_str(sol.status),
                       sol.iterations);
            }
            if (sol.status == BF_STATUS_SOLVED) {
                /* Node 0 is the measured state, from the plan's
                 * interpolant, which can be a little outside a limit
                 * (20.03 deg/s here) that the plan's nodes hold. */
                size_t ok = 1;
                for (size_t j = 1; j < sol.node_count; j++) {
                    ok += (size_t)holds_limits(&sol.nodes[j]);
                }
                solved++;
                solved_held += ok == sol.node_count;
            }
        }
        /* 19 of 20 solve here: one, at 121 m, uses up its budget and keeps
         * the old plan, as a flight loop must. */
        CHECK(replans == 20 && solved >= 18, "%d of %d re-plans solved", solved, replans);
        CHECK(solved_held == solved, "%d of %d solved re-plans hold every limit at their nodes",
              solved_held, solved);
    }
    bf_solver_free(s);
    bf_problem_free(p);
    p = NULL;
    s = NULL;
    snprintf(text, sizeof text, "%s%s", PAPER_TOML, CONE);
    CHECK(bf_problem_from_toml_str(text, &p) == BF_ERROR_OK, "the cone's TOML");
    CHECK(p && bf_solver_new(p, &settings, &s) == BF_ERROR_OK, "solver with a cone");
    if (s) {
        const double tan_gamma = tan(11.0 * 3.14159265358979323846 / 180.0);
        int inside = 0, replans = 0, solved = 0, solved_inside = 0;
        CHECK(bf_solve(s, &sol) == BF_ERROR_OK && sol.status == BF_STATUS_SOLVED && sol.adopted,
              "cold solve with a cone: %s, adopted %d", bf_status_str(sol.status), sol.adopted);
        for (size_t k = 0; k < sol.node_count; k++) {
            inside += inside_cone(&sol.nodes[k], tan_gamma);
        }
        CHECK(inside == (int)n_nodes, "%d of %zu nodes inside the cone", inside, n_nodes);
        const double tf = sol.tf_s;
        for (int k = 1; k <= 10; k++) {
            bf_state x;
            double t = 0.06 * k * tf;
            if (bf_plan_state_at(s, t, &x) != BF_ERROR_OK ||
                bf_replan(s, &x, t, &sol) != BF_ERROR_OK) {
                continue;
            }
            replans++;
            if (getenv("BF_TEST_VERBOSE")) {
                printf("cone: t=%.3f x=%.1f z=%.1f %s its=%u\n", t, x.x_m, x.z_m,
                       bf_status_str(sol.status), sol.iterations);
            }
            if (sol.status == BF_STATUS_SOLVED) {
                size_t ok = 1; /* node 0: the measured state */
                for (size_t j = 1; j < sol.node_count; j++) {
                    ok += (size_t)inside_cone(&sol.nodes[j], tan_gamma);
                }
                solved++;
                solved_inside += ok == sol.node_count;
            }
        }
        /* 8 of 10 solve here; the last two, 104 and 140 m above the pad
         * where the cone is 20-27 m wide, stall in the restoration phase
         * (not_converged: "locally infeasible", not a proof) and keep the
         * old plan. */
        CHECK(replans == 10 && solved >= 7, "%d of %d cone re-plans solved", solved, replans);
        CHECK(solved_inside == solved, "%d of %d solved re-plans inside the cone at their nodes",
              solved_inside, solved);
    }
    bf_solver_free(s);
    bf_problem_free(p);
    free(sol.nodes);
}

static void budgets_end_a_call(bf_problem *paper, size_t n_nodes) {
    bf_solution sol = solution_with(n_nodes);
    bf_settings settings = bf_settings_default();
    bf_solver *s = NULL;
    settings.solve_max_iterations = 3;
    CHECK(bf_solver_new(paper, &settings, &s) == BF_ERROR_OK, "solver with a 3-iteration budget");
    CHECK(bf_solve(s, &sol) == BF_ERROR_OK, "bf_solve");
    CHECK(sol.status == BF_STATUS_NOT_CONVERGED, "status %s", bf_status_str(sol.status));
    CHECK(sol.iterations == 3, "iterations %u", sol.iterations);
    CHECK(!sol.adopted && isfinite(sol.tf_s), "an unconverged iterate is returned, not adopted");
    bf_solver_free(s);
    settings = bf_settings_default();
    settings.time_budget_s = 1e-9;
    CHECK(bf_solver_new(paper, &settings, &s) == BF_ERROR_OK, "solver with a 1-ns budget");
    CHECK(bf_solve(s, &sol) == BF_ERROR_OK, "bf_solve");
    CHECK(sol.status == BF_STATUS_NOT_CONVERGED, "status %s", bf_status_str(sol.status));
    CHECK(sol.iterations <= 2, "iterations %u: the deadline ends a phase after one", sol.iterations);
    CHECK(strcmp(bf_status_str(sol.status), "not_converged") == 0, "status name");
    bf_solver_free(s);
    free(sol.nodes);
}

int main(int argc, char **argv) {
    if (argc != 3) {
        fprintf(stderr, "usage: %s TF_BITS MF_BITS\n", argv[0]);
        return 2;
    }
    uint64_t tf_bits = strtoull(argv[1], NULL, 16), mf_bits = strtoull(argv[2], NULL, 16);
    bf_problem *paper = NULL;
    bf_solver *solver = NULL;
    size_t n_nodes = 0;
    bf_settings settings = bf_settings_default();
    CHECK(bf_problem_paper(&paper) == BF_ERROR_OK, "bf_problem_paper");
    CHECK(bf_problem_node_count(paper, &n_nodes) == BF_ERROR_OK && n_nodes > 2, "%zu nodes", n_nodes);
    CHECK(bf_solver_new(paper, &settings, &solver) == BF_ERROR_OK, "bf_solver_new");
    if (failed) {
        fprintf(stderr, "c_api: %d passed, %d failed\n", passed, failed);
        return 1;
    }
    cold_solve_matches_rust(solver, n_nodes, tf_bits, mf_bits);
    replans_along_a_flight(solver, n_nodes);
    null_pointers(paper, solver, n_nodes);
    bad_numbers(paper, solver, n_nodes);
    bad_text_and_buffers(solver, n_nodes);
    budgets_end_a_call(paper, n_nodes);
    constraints_from_toml(n_nodes);
    bf_solver_free(solver);
    bf_problem_free(paper);
    printf("c_api: %d passed, %d failed\n", passed, failed);
    return failed ? 1 : 0;
}
