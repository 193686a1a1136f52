//! Dense sampling of a solution from its LGR interpolants, as the plots and
//! trajectory.csv draw it: [`bellyflop::output::samples`], kept as columns
//! with the node markers.

use bellyflop::{Scenario, Solution};

/// A trajectory sampled in time, in SI units and radians.
///
/// Every column has the same length. The same type carries the solution's
/// interpolants ([`Dense::from_solution`]) and, for overlays, any other
/// trajectory given by its columns ([`Dense::from_columns`]).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Dense {
    pub t_s: Vec<f64>,
    pub x_m: Vec<f64>,
    pub z_m: Vec<f64>,
    pub vx_mps: Vec<f64>,
    pub vz_mps: Vec<f64>,
    pub theta_rad: Vec<f64>,
    pub pitch_rate_radps: Vec<f64>,
    pub mass_kg: Vec<f64>,
    pub delta_rad: Vec<f64>,
    pub thrust_n: Vec<f64>,
    pub gimbal_rate_radps: Vec<f64>,
    /// `Some(k)` where the sample is LGR node k (0 ≤ k ≤ N), else `None`.
    pub node: Vec<Option<usize>>,
}

/// The columns of a [`Dense`] trajectory in the order of the CSV file:
/// (header, accessor).
pub type Column = (&'static str, fn(&Dense) -> &[f64]);

/// Every numeric column, in CSV order, with its unit in the name.
pub const COLUMNS: [Column; 11] = [
    ("t_s", |d| &d.t_s),
    ("x_m", |d| &d.x_m),
    ("z_m", |d| &d.z_m),
    ("vx_mps", |d| &d.vx_mps),
    ("vz_mps", |d| &d.vz_mps),
    ("theta_rad", |d| &d.theta_rad),
    ("pitch_rate_radps", |d| &d.pitch_rate_radps),
    ("mass_kg", |d| &d.mass_kg),
    ("delta_rad", |d| &d.delta_rad),
    ("thrust_n", |d| &d.thrust_n),
    ("gimbal_rate_radps", |d| &d.gimbal_rate_radps),
];

impl Dense {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.t_s.len()
    }

    /// Sample the answer: `per_interval` samples on each of the N
    /// intervals between consecutive LGR nodes, plus the final node; a
    /// polished answer as it flies, else its interpolants
    /// ([`bellyflop::output::samples::of`], which the viewer draws too).
    pub fn from_solution(scenario: &Scenario, s: &Solution, per_interval: usize) -> Dense {
        let samples = bellyflop::output::samples::of(scenario, s, per_interval);
        Dense {
            node: samples.node,
            ..Dense::from_columns(samples.columns)
        }
    }

    /// The solution's node values only (N + 1 samples), as stored in the
    /// [`Solution`] arrays.
    pub fn nodes_of(s: &Solution) -> Dense {
        Dense {
            t_s: s.t_s.clone(),
            x_m: s.x_m.clone(),
            z_m: s.z_m.clone(),
            vx_mps: s.vx_mps.clone(),
            vz_mps: s.vz_mps.clone(),
            theta_rad: s.theta_rad.clone(),
            pitch_rate_radps: s.pitch_rate_radps.clone(),
            mass_kg: s.mass_kg.clone(),
            delta_rad: s.delta_rad.clone(),
            thrust_n: s.thrust_n.clone(),
            gimbal_rate_radps: s.gimbal_rate_radps.clone(),
            node: (0..s.t_s.len()).map(Some).collect(),
        }
    }

    /// A trajectory from its columns (e.g. a re-integrated one, for the dashed
    /// overlay of the plots). `columns` are in the order of [`COLUMNS`]; all
    /// must have the same length. No sample is marked as a node.
    ///
    /// # Panics
    /// Panics if the columns differ in length.
    pub fn from_columns(columns: [Vec<f64>; 11]) -> Dense {
        let len = columns[0].len();
        assert!(
            columns.iter().all(|c| c.len() == len),
            "all columns need the same length"
        );
        let [t_s, x_m, z_m, vx_mps, vz_mps, theta_rad, pitch_rate_radps, mass_kg, delta_rad, thrust_n, gimbal_rate_radps] =
            columns;
        Dense {
            t_s,
            x_m,
            z_m,
            vx_mps,
            vz_mps,
            theta_rad,
            pitch_rate_radps,
            mass_kg,
            delta_rad,
            thrust_n,
            gimbal_rate_radps,
            node: vec![None; len],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bellyflop::Scenario;

    fn solution(n: usize) -> Solution {
        let mut s = Scenario::paper();
        s.discretization.nodes = n;
        bellyflop::solve(
            &s,
            &Default::default(),
            &mut bellyflop::method::observer::Silent,
        )
        .expect("a planar scenario")
    }

    #[test]
    fn nodes_are_sampled_exactly() {
        let s = solution(10);
        let d = Dense::from_solution(&bellyflop::Scenario::paper(), &s, 7);
        assert_eq!(d.len(), 10 * 7 + 1);
        assert!(COLUMNS.iter().all(|(_, c)| c(&d).len() == d.len()));
        let nodes = Dense::nodes_of(&s);
        let mut seen = 0;
        for (i, k) in d.node.iter().enumerate() {
            if let Some(k) = *k {
                seen += 1;
                assert_eq!(d.t_s[i], nodes.t_s[k]);
                for (name, col) in COLUMNS {
                    if name == "thrust_n" || name == "gimbal_rate_radps" {
                        let rel =
                            (col(&d)[i] - col(&nodes)[k]).abs() / col(&nodes)[k].abs().max(1.0);
                        assert!(rel < 1e-12, "{name} at node {k}");
                    } else if name == "mass_kg" {
                        assert!((col(&d)[i] / col(&nodes)[k] - 1.0).abs() < 1e-15);
                    } else {
                        assert_eq!(col(&d)[i], col(&nodes)[k], "{name} at node {k}");
                    }
                }
            }
        }
        assert_eq!(seen, 11);
        assert!(d.t_s.windows(2).all(|w| w[0] < w[1]));
    }

    /// The top-level keys of a JSON object's text, in the order written.
    fn keys_in_order(text: &str) -> Vec<String> {
        struct Keys;
        impl<'de> serde::de::Visitor<'de> for Keys {
            type Value = Vec<String>;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a JSON object")
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(
                self,
                mut map: A,
            ) -> Result<Vec<String>, A::Error> {
                let mut keys = Vec::new();
                while let Some(k) = map.next_key::<String>()? {
                    map.next_value::<serde::de::IgnoredAny>()?;
                    keys.push(k);
                }
                Ok(keys)
            }
        }
        use serde::Deserializer as _;
        serde_json::Deserializer::from_str(text)
            .deserialize_map(Keys)
            .expect("a JSON object")
    }

    /// `COLUMNS` are the node arrays of the solution's JSON (the keys whose
    /// values are N + 1 numbers), by name, in the `Solution`'s field order,
    /// and each column of `Dense::nodes_of` is that array.
    #[test]
    fn columns_are_the_solutions_node_arrays() {
        let s = solution(Scenario::paper().discretization.nodes);
        let v = s.to_json();
        let obj = v.as_object().expect("a JSON object");
        let is_node_array = |v: &serde_json::Value| {
            v.as_array()
                .is_some_and(|a| a.len() == s.nodes + 1 && a.iter().all(|x| x.is_number()))
        };
        let order = keys_in_order(&serde_json::to_string(&s).expect("a Solution serializes"));
        let node_arrays: Vec<&str> = order
            .iter()
            .map(String::as_str)
            .filter(|k| obj.get(*k).is_some_and(is_node_array))
            .collect();
        assert_eq!(
            obj.iter().filter(|(_, v)| is_node_array(v)).count(),
            node_arrays.len(),
            "every node array of to_json() is a field of the Solution"
        );
        let names: Vec<&str> = COLUMNS.iter().map(|(name, _)| *name).collect();
        assert_eq!(names, node_arrays);
        let d = Dense::nodes_of(&s);
        for (name, col) in COLUMNS {
            let json: Vec<f64> = obj[name]
                .as_array()
                .unwrap()
                .iter()
                .map(|x| x.as_f64().unwrap())
                .collect();
            assert_eq!(col(&d), &json[..], "{name}");
        }
    }
}
