/* A minimal re-planning loop in C around bellyflop's C API.
 *
 * The plant is the planner's own rigid-body model (Eq. 8 of the paper:
 * planar translation and pitch with drag, mass flow from I_sp, the nozzle
 * angle driven by a rate command), integrated with RK4 at 100 Hz, with the
 * paper's vehicle (scenarios/paper.toml) and one disturbance the planner
 * does not know about: the engine gives 1 % more thrust than commanded
 * (THRUST_EFFICIENCY). The re-plans absorb it. An engine that gives less
 * than commanded is another matter: the paper's problem plans its last
 * burn on the thrust limit, so from a state behind the plan the final-burn
 * re-plans are infeasible and the old plan is flown on (measured: from
 * 7 s on at 0.995 and 1.0, where the open-loop flight drifts from the
 * plan; a miss of 1.7 m at 0.995, 5.5 m at 0.98). Guidance (`bellyflop
 * sim`) plans with thrust margins, to a gate above the pad, with feedback,
 * for that reason.
 * Between re-plans the loop flies the current plan open loop: thrust
 * T = sigma(t) * m (the plan's thrust per mass times the mass) and a nozzle
 * rate that follows the plan's nozzle angle. Every second it re-plans with
 * bf_replan from the state it measures (here: the true state), until the
 * plan has less than 1.5 s to go; then it flies the last plan to its end and
 * prints the miss against the target (the pad, at rest, upright).
 *
 * Exit status: 0 if every call succeeded, at least one re-plan solved, and
 * the miss is within 2 m and 2 m/s; 1 otherwise.
 *
 * Build and run: make -C examples/c run */
#include "bellyflop.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

/* The paper's vehicle (scenarios/paper.toml, Table 1). */
#define PI 3.14159265358979323846
#define G0 9.81
#define ISP_S 330.0
#define LENGTH_M 50.0
#define RADIUS_M 4.5
#define CG_M 20.0
#define CP_M 22.5
#define C_LD 195.52
#define T_MIN_N 880000.0
#define T_MAX_N 2210000.0
#define CHI_MAX_RADPS (20.0 * PI / 180.0)
#define DELTA_MAX_RAD (20.0 * PI / 180.0)

#define DT_S 0.01            /* plant step */
#define REPLAN_PERIOD_S 1.0  /* re-plan every second */
#define STOP_TIME_TO_GO_S 1.5
#ifndef THRUST_EFFICIENCY
#define THRUST_EFFICIENCY 1.01
#endif

/* State derivative of (x, z, vx, vz, theta, w, m, delta) under thrust T and
 * nozzle rate chi (the physical model of crates/bellyflop/src/problem/
 * dynamics.rs, rhs_physical and rhs_augmented). */
static void rhs(const double s[8], double thrust_n, double chi, double out[8]) {
    const double k = 6.0 * RADIUS_M * RADIUS_M + LENGTH_M * LENGTH_M;
    double vx = s[2], vz = s[3], theta = s[4], w = s[5], m = s[6], delta = s[7];
    double speed = sqrt(vx * vx + vz * vz + 1e-12);
    double dx = -C_LD * speed * vx, dz = -C_LD * speed * vz;
    double phi = theta + delta;
    double moment = -(thrust_n * sin(delta)) * CG_M - (dx * cos(theta) + dz * sin(theta)) * (CP_M - CG_M);
    out[0] = vx;
    out[1] = vz;
    out[2] = (-thrust_n * sin(phi) + dx) / m;
    out[3] = (thrust_n * cos(phi) + dz) / m - G0;
    out[4] = w;
    out[5] = moment / (m * k / 12.0);
    out[6] = -thrust_n / (ISP_S * G0);
    out[7] = chi;
}

static void rk4(double s[8], double thrust_n, double chi, double h) {
    double k1[8], k2[8], k3[8], k4[8], t[8];
    int i;
    rhs(s, thrust_n, chi, k1);
    for (i = 0; i < 8; i++) t[i] = s[i] + 0.5 * h * k1[i];
    rhs(t, thrust_n, chi, k2);
    for (i = 0; i < 8; i++) t[i] = s[i] + 0.5 * h * k2[i];
    rhs(t, thrust_n, chi, k3);
    for (i = 0; i < 8; i++) t[i] = s[i] + h * k3[i];
    rhs(t, thrust_n, chi, k4);
    for (i = 0; i < 8; i++) s[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
}

static bf_state as_bf_state(const double s[8]) {
    bf_state x = {s[0], s[1], s[2], s[3], s[4], s[5], s[6], s[7]};
    return x;
}

static double clamp(double v, double lo, double hi) { return v < lo ? lo : v > hi ? hi : v; }

/* Stop on a failed call, with its error and message. */
#define TRY(call)                                                                     \
    do {                                                                              \
        bf_error e_ = (call);                                                         \
        if (e_ != BF_ERROR_OK) {                                                      \
            fprintf(stderr, "%s: %s: %s\n", #call, bf_error_str(e_), bf_last_error()); \
            exit(1);                                                                  \
        }                                                                             \
    } while (0)

int main(void) {
    bf_problem *problem = NULL;
    bf_solver *solver = NULL;
    bf_settings settings = bf_settings_default();
    size_t n = 0;
    TRY(bf_problem_paper(&problem));
    TRY(bf_solver_new(problem, &settings, &solver));
    TRY(bf_solver_node_count(solver, &n));
    bf_solution sol = {0};
    sol.nodes = (bf_node *)calloc(n, sizeof(bf_node));
    sol.node_capacity = n;
    if (!sol.nodes) return 1;

    TRY(bf_solve(solver, &sol));
    if (sol.status != BF_STATUS_SOLVED) {
        fprintf(stderr, "cold solve: %s\n", bf_status_str(sol.status));
        return 1;
    }
    printf("cold solve: t_f %.3f s, m_f %.1f kg, %u iterations, %.1f ms\n", sol.tf_s,
           sol.final_mass_kg, sol.iterations, sol.solve_time_ms);

    bf_state x0;
    TRY(bf_problem_initial_state(problem, &x0));
    double s[8] = {x0.x_m, x0.z_m, x0.vx_mps, x0.vz_mps, x0.theta_rad, x0.pitch_rate_radps,
                   x0.mass_kg, x0.gimbal_rad};
    double t = 0.0, next_replan = REPLAN_PERIOD_S, plan_start = 0.0, tf = sol.tf_s;
    int replans = 0, solved = 0;
    for (;;) {
        if (t + 1e-9 >= next_replan && tf - (t - plan_start) > STOP_TIME_TO_GO_S) {
            bf_state measured = as_bf_state(s);
            next_replan += REPLAN_PERIOD_S;
            TRY(bf_replan(solver, &measured, t, &sol));
            replans++;
            solved += sol.adopted;
            TRY(bf_plan_start_s(solver, &plan_start));
            if (sol.adopted) tf = sol.tf_s;
            printf("t %5.2f s  z %7.2f m  re-plan %-13s %2u iterations %6.2f ms  t_f %.3f s  m_f %.1f kg\n",
                   t, s[1], bf_status_str(sol.status), sol.iterations, sol.solve_time_ms,
                   sol.tf_s, sol.final_mass_kg);
        }
        if (t - plan_start >= tf - 0.5 * DT_S) break; /* the plan's end: touchdown */
        double h = fmin(DT_S, tf - (t - plan_start));
        double sigma, delta_now, sigma_next, delta_next;
        TRY(bf_plan_controls_at(solver, t, &sigma, &delta_now));
        TRY(bf_plan_controls_at(solver, t + h, &sigma_next, &delta_next));
        double thrust = clamp(sigma * s[6], T_MIN_N, T_MAX_N) * THRUST_EFFICIENCY;
        double chi = clamp((clamp(delta_next, -DELTA_MAX_RAD, DELTA_MAX_RAD) - s[7]) / h,
                           -CHI_MAX_RADPS, CHI_MAX_RADPS);
        rk4(s, thrust, chi, h);
        t += h;
    }

    double miss_m = hypot(s[0], s[1]), speed = hypot(s[2], s[3]);
    printf("touchdown at t %.3f s: x %.3f m, z %.3f m, vx %.3f m/s, vz %.3f m/s, theta %.2f deg, "
           "mass %.1f kg\n",
           t, s[0], s[1], s[2], s[3], s[4] * 180.0 / PI, s[6]);
    printf("miss: %.3f m, %.3f m/s (%d re-plans, %d solved)\n", miss_m, speed, replans, solved);
    free(sol.nodes);
    bf_solver_free(solver);
    bf_problem_free(problem);
    return (solved > 0 && miss_m <= 2.0 && speed <= 2.0) ? 0 : 1;
}
