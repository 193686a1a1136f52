//! Issue 38: the Rust 6-DoF model (`problem::six_dof`) against the one the
//! IPOPT reference writes apart from it (`bench/reference/nlp_6dof.py`), at
//! 50 seeded states out of the plane, with a wind along and across x and
//! quaternions off the unit sphere by up to 2 % (the normalisation inside R
//! and the pull count too). The fixture is written by
//! `bench/reference/six_dof_fixture.py`.

use bellyflop::input::scenario::Scenario;
use bellyflop::problem::six_dof::{self, SixDof, NU, NX};
use bellyflop::Mesh;

/// A fixture's array of numbers.
fn read(v: &serde_json::Value) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

/// IPOPT's 6-DoF answers, the paper's scenario and model, and their mesh.
fn answers() -> (serde_json::Value, Scenario, SixDof, Mesh) {
    let data: serde_json::Value =
        serde_json::from_str(include_str!("data/six_dof_answers.json")).unwrap();
    let paper = Scenario::paper();
    let model = SixDof::new(&paper.vehicle, &paper.environment);
    let mesh = Mesh::global(data["nodes"].as_u64().unwrap() as usize);
    (data, paper, model, mesh)
}

#[test]
fn the_model_agrees_with_the_references_own() {
    let text = include_str!("data/six_dof_rhs.json");
    let data: serde_json::Value = serde_json::from_str(text).unwrap();
    let paper = Scenario::paper();
    let mut model = SixDof::new(&paper.vehicle, &paper.environment);
    assert_eq!(data["kappa_per_s"].as_f64(), Some(model.norm_gain_per_s));
    let cases = data["cases"].as_array().unwrap();
    assert_eq!(cases.len(), 50);
    for (k, case) in cases.iter().enumerate() {
        let s: [f64; NX] = read(&case["state"]).try_into().unwrap();
        let u: [f64; NU] = read(&case["control"]).try_into().unwrap();
        model.wind_mps = read(&case["wind_mps"]).try_into().unwrap();
        let want = read(&case["rhs"]);
        let got = six_dof::rhs(&model, &s, &u);
        for i in 0..NX {
            let scale = want[i].abs().max(1e-6);
            assert!(
                (got[i] - want[i]).abs() <= 1e-10 * scale,
                "case {k}, slot {i}: {} against the reference's {}",
                got[i],
                want[i]
            );
        }
    }
}

/// Issue 38: IPOPT's answers of its 6-DoF transcription (three seeded 3-D
/// states at N = 20, `bench/reference/six_dof_fixture.py`) satisfy ours,
/// evaluated through the model seam (`collocation::residuals`): the same
/// mesh, dynamics, boxes, gimbal rows and landing, to IPOPT's tolerances.
/// So a side-by-side of a 6-DoF solve against IPOPT compares one problem.
/// A t_f off by 0.1 % is seen.
#[test]
fn the_references_answers_satisfy_our_transcription() {
    use bellyflop::collocation::residuals::{residuals, Answer};
    use bellyflop::problem::six_dof::sx;

    let (data, paper, model, mesh) = answers();
    let worst = |v: &[f64]| v.iter().cloned().fold(0.0, f64::max);
    let answers = data["answers"].as_array().unwrap();
    assert_eq!(answers.len(), 3);
    for a in answers {
        let name = a["name"].as_str().unwrap();
        assert!(a["converged"].as_bool().unwrap(), "{name}");
        let (start, states, controls) =
            (read(&a["start"]), read(&a["states"]), read(&a["controls"]));
        // Out of the plane, as the box asks.
        assert!(
            start[sx::Y].abs() > 1.0 && start[sx::W + 2].abs() > 1e-4,
            "{name}"
        );
        let answer = Answer {
            states: &states,
            controls: &controls,
            tf_s: a["tf_s"].as_f64().unwrap(),
        };
        let r = residuals(&model, &mesh, &start, &paper.terminal, &answer).unwrap();
        // The reference's scales: 100 for r and V, m0 for m, 1 otherwise;
        // its tolerance 1e-9 on the scaled rows (the largest seen: 1.6e-9 kg
        // of mass, 7.5e-10 m/s, 2.8e-10 of q), and its bounds relaxed by
        // 1e-8 of the scaled variable (1e-6 m of the ground, 0.07 N of T).
        let scale = |c: usize| match c {
            c if c < 6 => 100.0,
            sx::M => start[sx::M],
            _ => 1.0,
        };
        for (c, d) in r.defect.iter().enumerate() {
            assert!(*d < 1e-8 * scale(c), "{name}: defect of state {c} is {d}");
        }
        assert!(r.initial < 1e-6, "{name}: {r:?}");
        assert!(worst(&r.state_box) < 2e-6, "{name}: {r:?}");
        assert!(
            worst(&r.control_box) < 2e-8 * paper.vehicle.max_thrust_n,
            "{name}"
        );
        assert!(worst(&r.path) < 1e-7, "{name}: {r:?}");
        assert!(worst(&r.terminal_fixed) < 1e-6, "{name}: {r:?}");
        let off = Answer {
            tf_s: answer.tf_s * 1.001,
            ..answer
        };
        let r = residuals(&model, &mesh, &start, &paper.terminal, &off).unwrap();
        assert!(
            (0..NX).any(|c| r.defect[c] > 1e-3 * scale(c)),
            "{name}: {r:?}"
        );
    }
}

/// Issue 38: the same answers' controls flown by our generic flight
/// (`verify::flight`, the 6-DoF model through the seam) end where scipy's
/// DOP853 flight of the reference's own model ends (`reintegrate6`): the
/// thrust linear between the collocation times, the gimbal angles linear
/// between the nodes. So the accuracy baseline of IPOPT's 6-DoF answers
/// (they miss the pad by metres; two of these three go through the
/// ground) is ours too.
#[test]
fn the_references_answers_fly_as_the_reference_flies_them() {
    use bellyflop::problem::six_dof::{su, sx};
    use bellyflop::verify::flight::{collocation_controls, fly};
    use bellyflop::verify::ode::Dop853;

    let (data, paper, model, mesh) = answers();
    let mut through_ground = 0;
    for a in data["answers"].as_array().unwrap() {
        let name = a["name"].as_str().unwrap();
        let tf = a["tf_s"].as_f64().unwrap();
        let x: Vec<[f64; NX]> = read(&a["states"])
            .chunks(NX)
            .map(|c| c.try_into().unwrap())
            .collect();
        let u: Vec<[f64; NU]> = read(&a["controls"])
            .chunks(NU)
            .map(|c| c.try_into().unwrap())
            .collect();
        let times: Vec<f64> = mesh.nodes.iter().map(|t| 0.5 * (t + 1.0) * tf).collect();
        let rates = [(sx::DELTA, su::CHI), (sx::DELTA + 1, su::CHI + 1)];
        let start: [f64; NX] = read(&a["start"]).try_into().unwrap();
        let flight = fly(
            &model,
            start,
            &times,
            collocation_controls(&times, &x, &u, &rates),
            &Dop853::default(),
        )
        .unwrap();
        let want = read(&a["flown_end"]);
        for (c, (got, want)) in flight.end().iter().zip(&want).enumerate() {
            assert!(
                // 7.4e-10 at most, relative: two DOP853s at 1e-10.
                (got - want).abs() < 1e-8 * (1.0 + want.abs()),
                "{name}, slot {c}: {got} against the reference's {want}"
            );
        }
        let lowest = a["flown_lowest_z_m"].as_f64().unwrap();
        // Ours is the least of the accepted steps, theirs of a 1 ms grid:
        // equal where the lowest point is the landing (here, to 3e-10 m).
        assert!((flight.lowest_altitude_m - lowest).abs() < 1e-3, "{name}");
        if flight.lowest_altitude_m < paper.terminal.z_m - 1.0 {
            through_ground += 1;
        }
    }
    assert_eq!(through_ground, 2);
}

/// Issue 38: our interior point solves the 6-DoF transcription (the
/// generic one behind the seam, with the nozzle cone and the rate disc as
/// barrier rows) from the reference's straight line, and cold (from a
/// coarse answer, as the planar default), and reaches IPOPT's
/// answers of the same transcription at the same mesh: the final mass
/// within 0.5 kg (the bound) and t_f within 1 ms, with every
/// defect, box, row and landing slot held as tightly as IPOPT's own.
#[test]
fn the_interior_point_reaches_the_references_6dof_answers() {
    use bellyflop::collocation::residuals::{residuals, Answer};
    use bellyflop::method::direct::six_dof::Nlp6;
    use bellyflop::method::observer::Silent;
    use bellyflop::problem::six_dof::sx;
    use bellyflop::Status;

    let (data, paper, model, mesh) = answers();
    for a in data["answers"].as_array().unwrap() {
        let name = a["name"].as_str().unwrap();
        let start: [f64; NX] = read(&a["start"]).try_into().unwrap();
        let nlp = Nlp6::six_dof(model.clone(), mesh.clone(), start, &paper.terminal);
        let w0 = nlp.straight_line(paper.discretization.tf_guess_s, start[sx::M] - 5000.0);
        let settings = bellyflop::input::settings::DirectSettings::default();
        let r = bellyflop::method::direct::solve_nlp(&nlp, &w0, None, &settings, &mut Silent);
        let tf = nlp.tf_s(&r.w);
        let mf = nlp.physical(sx::M, r.w[nlp.idx(nlp.n, sx::M)]);
        let (want_tf, want_mf) = (a["tf_s"].as_f64().unwrap(), a["mf_kg"].as_f64().unwrap());
        eprintln!(
            "{name}: {:?} in {} iterations, t_f {tf:.6} s ({want_tf:.6}), m_f {mf:.4} kg ({want_mf:.4})",
            r.status,
            r.history.len()
        );
        let (states, controls) = nlp.physical_answer(&r.w);
        let answer = Answer {
            states: &states,
            controls: &controls,
            tf_s: tf,
        };
        let res = residuals(&model, &mesh, &start, &paper.terminal, &answer).unwrap();
        let worst = |v: &[f64]| v.iter().cloned().fold(0.0, f64::max);
        eprintln!("{name}: {res:?}");
        assert!(worst(&res.path) <= 0.0, "{name}: {res:?}");
        assert!(worst(&res.terminal_fixed) < 1e-9, "{name}: {res:?}");
        assert_eq!(r.status, Status::Solved, "{name}: {}", r.message);
        // Never more than 0.5 kg below IPOPT's (the bound); where
        // it is the same optimum, the same t_f.
        assert!(mf > want_mf - 0.5, "{name}: m_f {mf} against {want_mf}");
        if (mf - want_mf).abs() < 0.5 {
            assert!(
                (tf - want_tf).abs() < 1e-3,
                "{name}: t_f {tf} against {want_tf}"
            );
        }
        // The cold solve (a coarse start at N = 10, then N = 20 from it)
        // reaches the same answer.
        let cold = bellyflop::method::direct::six_dof::solve_cold(
            &nlp,
            paper.discretization.tf_guess_s,
            start[sx::M] - 5000.0,
            &settings,
            &mut Silent,
        );
        assert_eq!(cold.status, Status::Solved, "{name}: {}", cold.message);
        let mf_cold = nlp.physical(sx::M, cold.w[nlp.idx(nlp.n, sx::M)]);
        assert!(
            (mf_cold - mf).abs() < 0.01,
            "{name}: cold m_f {mf_cold} against {mf}"
        );
    }
}

/// Issue 38's planar special case: the 6-DoF solve of the paper's case (y =
/// V_y = 0, the attitude in the x–z plane) gives the planar answer, t_f
/// and m_f within 1e-6 relative, with every out-of-plane state at zero.
#[test]
fn the_paper_case_in_3d_is_the_planar_answer() {
    use bellyflop::input::settings::{DirectSettings, SolverSettings};
    use bellyflop::method::direct::six_dof::{solve_cold, Nlp6};
    use bellyflop::method::observer::Silent;
    use bellyflop::problem::six_dof::{planar_state, sx};
    use bellyflop::Status;

    let paper = Scenario::paper();
    let planar = bellyflop::method::direct::solve(&paper, &SolverSettings::default(), &mut Silent);
    assert_eq!(planar.status, Status::Solved, "{}", planar.message);
    let y = paper.initial.state_si();
    let model = SixDof::new(&paper.vehicle, &paper.environment);
    let mesh = paper.discretization.collocation_mesh();
    let nlp = Nlp6::six_dof(model, mesh, planar_state(&y), &paper.terminal);
    let d = &paper.discretization;
    let r = solve_cold(
        &nlp,
        d.tf_guess_s,
        d.final_mass_guess_kg,
        &DirectSettings::default(),
        &mut Silent,
    );
    assert_eq!(r.status, Status::Solved, "{}", r.message);
    let tf = nlp.tf_s(&r.w);
    let mf = nlp.physical(sx::M, r.w[nlp.idx(nlp.n, sx::M)]);
    let rel = |a: f64, b: f64| (a - b).abs() / b.abs();
    eprintln!(
        "6-DoF: t_f {tf:.9} s, m_f {mf:.6} kg; planar: t_f {:.9} s, m_f {:.6} kg",
        planar.tf_s, planar.final_mass_kg
    );
    assert!(
        rel(tf, planar.tf_s) < 1e-6,
        "t_f {tf} against {}",
        planar.tf_s
    );
    assert!(
        rel(mf, planar.final_mass_kg) < 1e-6,
        "m_f {mf} against {}",
        planar.final_mass_kg
    );
    let out_of_plane = [
        sx::Y,
        sx::VY,
        sx::Q + 1,
        sx::Q + 3,
        sx::W,
        sx::W + 2,
        sx::DELTA + 1,
    ];
    for k in 0..=nlp.n {
        for s in out_of_plane {
            let v = nlp.physical(s, r.w[nlp.idx(k, s)]);
            assert!(v.abs() < 1e-9, "node {k}, state {s}: {v}");
        }
    }
}

/// q ⊗ p (scalar first).
fn quat_mul(q: [f64; 4], p: [f64; 4]) -> [f64; 4] {
    [
        q[0] * p[0] - q[1] * p[1] - q[2] * p[2] - q[3] * p[3],
        q[0] * p[1] + q[1] * p[0] + q[2] * p[3] - q[3] * p[2],
        q[0] * p[2] - q[1] * p[3] + q[2] * p[0] + q[3] * p[1],
        q[0] * p[3] + q[1] * p[2] - q[2] * p[1] + q[3] * p[0],
    ]
}

/// The state `s` turned by ψ about the vertical through the pad (x_f, 0):
/// position about the pad, velocity, and the attitude q_z(ψ) ⊗ q; the body
/// rates, the mass and the gimbal are the body's and stay.
fn turned(s: &[f64], psi: f64, pad_x_m: f64) -> Vec<f64> {
    use bellyflop::problem::six_dof::sx;
    let (c, sn) = (psi.cos(), psi.sin());
    let mut t = s.to_vec();
    let (x, y) = (s[sx::X] - pad_x_m, s[sx::Y]);
    t[sx::X] = pad_x_m + c * x - sn * y;
    t[sx::Y] = sn * x + c * y;
    t[sx::VX] = c * s[sx::VX] - sn * s[sx::VY];
    t[sx::VY] = sn * s[sx::VX] + c * s[sx::VY];
    let q: [f64; 4] = s[sx::Q..sx::Q + 4].try_into().unwrap();
    let yaw = [(psi / 2.0).cos(), 0.0, 0.0, (psi / 2.0).sin()];
    t[sx::Q..sx::Q + 4].copy_from_slice(&quat_mul(yaw, q));
    t
}

/// Issue 38's symmetry: a state turned about the vertical through the pad
/// (with the wind turned alike) gives the turned answer. The solver sees a
/// different problem (its scaling takes the larger of |x − x_f| and |y|),
/// so the answers agree to the solver's tolerance, not bit for bit: t_f to
/// 1e-6 s, m_f to 1e-3 kg, every node's state turned to 1e-4 m and m/s
/// and 1e-6 in q. And the quaternion keeps its norm along the answer, to
/// the collocation's accuracy.
#[test]
fn a_state_turned_about_the_vertical_gives_the_turned_answer() {
    use bellyflop::input::settings::DirectSettings;
    use bellyflop::method::direct::six_dof::{solve_cold, Nlp6};
    use bellyflop::method::observer::Silent;
    use bellyflop::problem::six_dof::sx;
    use bellyflop::Status;

    let (data, paper, mut model, mesh) = answers();
    model.wind_mps = [3.0, -2.0, 0.0];
    let pad = paper.terminal.x_m;
    let start: Vec<f64> = read(&data["answers"][0]["start"]);
    let solve = |model: &SixDof, start: &[f64]| {
        let x0: [f64; NX] = start.try_into().unwrap();
        let nlp = Nlp6::six_dof(model.clone(), mesh.clone(), x0, &paper.terminal);
        let d = &paper.discretization;
        let r = solve_cold(
            &nlp,
            d.tf_guess_s,
            x0[sx::M] - 5000.0,
            &DirectSettings::default(),
            &mut Silent,
        );
        assert_eq!(r.status, Status::Solved, "{}", r.message);
        let (states, _) = nlp.physical_answer(&r.w);
        (nlp.tf_s(&r.w), states)
    };
    let (tf, states) = solve(&model, &start);
    let worst_norm = states
        .chunks(NX)
        .map(|s| {
            (s[sx::Q..sx::Q + 4]
                .iter()
                .map(|v| v * v)
                .sum::<f64>()
                .sqrt()
                - 1.0)
                .abs()
        })
        .fold(0.0, f64::max);
    eprintln!("| |q| − 1 | along the answer: {worst_norm:.2e}");
    assert!(worst_norm < 1e-4, "|q| off 1 by {worst_norm}");
    for psi in [0.7f64, -2.5] {
        let mut turned_model = model.clone();
        let w = model.wind_mps;
        turned_model.wind_mps = [
            psi.cos() * w[0] - psi.sin() * w[1],
            psi.sin() * w[0] + psi.cos() * w[1],
            w[2],
        ];
        let (tf2, states2) = solve(&turned_model, &turned(&start, psi, pad));
        eprintln!("ψ = {psi}: t_f {tf2:.9} s against {tf:.9} s");
        assert!((tf2 - tf).abs() < 1e-6, "ψ = {psi}: t_f {tf2} against {tf}");
        for (k, (a, b)) in states.chunks(NX).zip(states2.chunks(NX)).enumerate() {
            let want = turned(a, psi, pad);
            for s in 0..NX {
                let tol = match s {
                    s if (sx::Q..sx::Q + 4).contains(&s) => 1e-6,
                    sx::M => 1e-3,
                    _ => 1e-4,
                };
                assert!(
                    (b[s] - want[s]).abs() < tol,
                    "ψ = {psi}, node {k}, state {s}: {} against {}",
                    b[s],
                    want[s]
                );
            }
        }
    }
}

/// The 6-DoF pipeline (`pipeline::six_dof::solve`) claims only what its
/// controls, flown, do: at N = 20 the raw answer of a 3-D fixture state
/// converges but misses the pad by more than the tolerances, so it is
/// `inaccurate`, with the miss in its message and its flown checks; its
/// tables take their names from the model.
#[test]
fn the_six_dof_pipeline_claims_what_its_flown_controls_do() {
    use bellyflop::method::observer::Silent;
    use bellyflop::pipeline::six_dof::solve;
    use bellyflop::{SolverSettings, Status};

    let (data, paper, _, _) = answers();
    let start: [f64; NX] = read(&data["answers"][0]["start"]).try_into().unwrap();
    let raw = SolverSettings {
        polish: false,
        ..SolverSettings::default()
    };
    // The miss falls as the mesh grows (1.3 m at N = 20, 0.11 m at 80),
    // but the flown secant rates of the gimbal break its bound at every N.
    let mut misses = Vec::new();
    for nodes in [20usize, 80] {
        let mut s = paper.clone();
        s.discretization.nodes = nodes;
        let sol = solve(&s, start, &raw, &mut Silent);
        let f = sol.flown.as_ref().expect("a converged answer is flown");
        eprintln!(
            "N = {nodes}: {:?}, miss {:.2e} m {:.2e} m/s, lowest {:.3} m, {}",
            sol.status, f.landing_miss_m, f.landing_miss_mps, f.lowest_altitude_m, sol.message
        );
        assert_eq!(sol.status, Status::Inaccurate, "{}", sol.message);
        misses.push(f.landing_miss_m);
    }
    assert!(misses[1] < misses[0] / 5.0, "{misses:?}");
    let sol = solve(&paper, start, &raw, &mut Silent);
    assert_eq!(sol.status, Status::Inaccurate, "{}", sol.message);
    assert!(sol.message.contains("from the target"), "{}", sol.message);
    let f = sol.flown.as_ref().unwrap();
    assert!(f.landing_miss_m > 0.1);
    assert_eq!(sol.states.names[1], "y_m");
    assert_eq!(sol.states.rows.len(), 21);
    assert_eq!(sol.controls.rows.len(), 20);
    let csv = sol.to_csv();
    assert!(csv.starts_with("t_s,x_m,y_m,z_m"), "{}", &csv[..40]);
    assert_eq!(csv.lines().count(), 22);
    let json = sol.to_json();
    assert_eq!(json["status"], "inaccurate");
    assert_eq!(json["model"], "6dof");
}

/// Issue 38's accuracy in 3-D: where the polished default says `solved`,
/// its controls, flown by DOP853, land within 1e-3 m and 1e-3 m/s, with no
/// ground contact before t_f and every bound held along the flight; where
/// it does not, it says why and publishes no flown controls. The polish
/// lands all three fixture states (box3d2's raw answer, flown, misses by
/// 117 m and goes 75 m below the pad).
#[test]
fn the_polished_six_dof_answer_lands_and_holds_its_bounds() {
    use bellyflop::method::observer::Silent;
    use bellyflop::pipeline::six_dof::solve;
    use bellyflop::{SolverSettings, Status};

    let (data, paper, model, _) = answers();
    let p = &model.planar;
    let mut solved = 0;
    for a in data["answers"].as_array().unwrap() {
        let name = a["name"].as_str().unwrap();
        let start: [f64; NX] = read(&a["start"]).try_into().unwrap();
        let sol = solve(&paper, start, &SolverSettings::default(), &mut Silent);
        let f = sol.flown.as_ref().expect("a converged answer is flown");
        eprintln!(
            "{name}: {:?} after {:?} polish iterations, m_f {:.3} kg, miss {:.2e} m {:.2e} m/s, lowest {:.4} m, nozzle {:.3}°, rate {:.3}°/s; {}",
            sol.status,
            sol.polish_iterations,
            sol.final_mass_kg,
            f.landing_miss_m,
            f.landing_miss_mps,
            f.lowest_altitude_m,
            f.max_gimbal_deg,
            f.max_gimbal_rate_degps,
            sol.message
        );
        if sol.status == Status::Solved {
            solved += 1;
            assert!(
                f.landing_miss_m < 1e-3 && f.landing_miss_mps < 1e-3,
                "{name}: {f:?}"
            );
            assert!(f.lowest_altitude_m > -1e-3, "{name}: {f:?}");
            assert!(f.max_gimbal_deg <= p.max_gimbal_rad.to_degrees() * (1.0 + 1e-9));
            assert!(f.max_gimbal_rate_degps <= p.max_gimbal_rate_radps.to_degrees() * (1.0 + 1e-9));
            assert!(f.thrust_range_n.0 >= p.min_thrust_n * (1.0 - 1e-9));
            assert!(f.thrust_range_n.1 <= p.max_thrust_n * (1.0 + 1e-9));
            let c = sol.controls_flown.as_ref().expect("published");
            assert_eq!(c.tf_s, sol.tf_s);
            assert_eq!(sol.states.rows.len(), c.tau.len());
        } else {
            assert_eq!(sol.status, Status::Inaccurate, "{name}");
            assert!(sol.message.contains("polish"), "{name}: {}", sol.message);
            assert!(sol.controls_flown.is_none());
        }
    }
    assert_eq!(solved, 3, "{solved} of 3 solved");
}
