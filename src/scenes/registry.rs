//! The one declaration of every scene: what the Python binding, `lagrangian.scenes` and its
//! stub are generated from.
//!
//! A scene is its Rust file (the parameter struct and its energies) plus an implementation of
//! [`Scene`]: its name, parameters with defaults, coordinates, route, docstring, how to draw it
//! and, where one is known, its exact solution. The macro `scenes!` in this file lists the
//! implementations once; the catalog ([`catalog`]), construction by name with arguments
//! checked by name ([`Arguments`]) and the Python model's enum over the scene systems are all
//! produced from that list. Adding a scene is one file and one line in `scenes!`.

use crate::dynamics::Dynamics;
use crate::error::{Error, Result};
use crate::rigid::Pose;
use crate::routes::{BodySystem, ParticleSystem, Particles, RigidBodies, System};
use crate::trace::TraceEnergies;

/// The kind and default of one parameter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Kind {
    /// A real number; `None` when it has no default.
    Number(Option<f64>),
    /// A list of real numbers (one per link of a chain); `None` when it has no default.
    List(Option<&'static [f64]>),
}

/// One parameter of a scene's constructor.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Parameter {
    /// The keyword in Python.
    pub name: &'static str,
    /// Number or list, and the default.
    pub kind: Kind,
    /// What it is, with its unit or role.
    pub doc: &'static str,
}

impl Parameter {
    /// A number with a default.
    pub const fn number(name: &'static str, default: f64, doc: &'static str) -> Self {
        Self {
            name,
            kind: Kind::Number(Some(default)),
            doc,
        }
    }

    /// A list of numbers with a default.
    pub const fn list(name: &'static str, default: &'static [f64], doc: &'static str) -> Self {
        Self {
            name,
            kind: Kind::List(Some(default)),
            doc,
        }
    }
}

/// How a scene names its coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Coordinates {
    /// These names, always.
    Fixed(&'static [&'static str]),
    /// `prefix1`, `prefix2`, … one per entry of the list parameter `per`.
    Numbered {
        /// The common prefix.
        prefix: &'static str,
        /// The list parameter whose length is the number of coordinates.
        per: &'static str,
    },
}

/// Which derivation of eq. 55 the scene's system takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Route {
    /// From the energies T, U, Φ written in generalized coordinates.
    Energy,
    /// From particle positions r_j(t, q) and masses.
    Particle,
    /// From the poses of rigid bodies, their masses and inertia tensors.
    Body,
}

impl Route {
    /// `"energy"`, `"particle"` or `"body"`.
    pub fn name(self) -> &'static str {
        match self {
            Route::Energy => "energy",
            Route::Particle => "particle",
            Route::Body => "body",
        }
    }
}

/// Everything about a scene that is not its physics: the catalog entry.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SceneInfo {
    /// The Python function name.
    pub name: &'static str,
    /// The Python docstring: what the system is and what its coordinates mean.
    pub doc: &'static str,
    /// The constructor's parameters, in Python's positional order.
    pub parameters: &'static [Parameter],
    /// The coordinates' names.
    pub coordinates: Coordinates,
    /// The route of the system built.
    pub route: Route,
    /// Whether [`Scene::exact`] gives the exact solution.
    pub exact: bool,
}

impl SceneInfo {
    /// The coordinate names for these arguments.
    pub fn coordinate_names(&self, args: &Arguments) -> Vec<String> {
        match self.coordinates {
            Coordinates::Fixed(names) => names.iter().map(|s| s.to_string()).collect(),
            Coordinates::Numbered { prefix, per } => (1..=args.list(per).len())
                .map(|i| format!("{prefix}{i}"))
                .collect(),
        }
    }
}

/// An argument value as given.
#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    /// A number.
    Number(f64),
    /// A list of numbers.
    List(Vec<f64>),
}

/// A scene's arguments checked by name: every parameter has a finite value of its kind.
#[derive(Debug, Clone, PartialEq)]
pub struct Arguments {
    info: &'static SceneInfo,
    values: Vec<Value>,
}

fn argument_error(scene: &'static str, parameter: &str, why: String) -> Error {
    Error::SceneArgument {
        scene,
        parameter: parameter.to_string(),
        why,
    }
}

impl Arguments {
    /// Check `given` (name, value) pairs against the scene's parameters: every name known and
    /// given once, every value finite and of the parameter's kind (a number where a list is
    /// expected is refused, and the other way round); missing parameters take their defaults.
    ///
    /// # Errors
    /// [`Error::SceneArgument`] naming the parameter: unknown, repeated, of the wrong kind, not
    /// finite, or missing without a default.
    pub fn new(info: &'static SceneInfo, given: Vec<(String, Value)>) -> Result<Self> {
        let scene = info.name;
        let mut values: Vec<Option<Value>> = vec![None; info.parameters.len()];
        for (name, value) in given {
            let Some(i) = info.parameters.iter().position(|p| p.name == name) else {
                let known: Vec<&str> = info.parameters.iter().map(|p| p.name).collect();
                return Err(argument_error(
                    scene,
                    &name,
                    format!(
                        "unknown parameter; the parameters are {}",
                        if known.is_empty() {
                            "none".to_string()
                        } else {
                            known.join(", ")
                        }
                    ),
                ));
            };
            if values[i].is_some() {
                return Err(argument_error(
                    scene,
                    &name,
                    "given twice: give it once".into(),
                ));
            }
            // Each message says what was given and what the parameter needs.
            match (&info.parameters[i].kind, &value) {
                (Kind::Number(_), Value::Number(x)) if !x.is_finite() => {
                    return Err(argument_error(
                        scene,
                        &name,
                        format!("the value {x} is not finite: give a finite number"),
                    ));
                }
                (Kind::List(_), Value::List(xs)) => {
                    if let Some(j) = xs.iter().position(|x| !x.is_finite()) {
                        return Err(argument_error(
                            scene,
                            &name,
                            format!(
                                "entry {j} of {xs:?} is {}, not finite: give finite numbers",
                                xs[j]
                            ),
                        ));
                    }
                }
                (Kind::Number(_), Value::List(xs)) => {
                    return Err(argument_error(
                        scene,
                        &name,
                        format!("must be a real number, got the list {xs:?}"),
                    ));
                }
                (Kind::List(_), Value::Number(x)) => {
                    return Err(argument_error(
                        scene,
                        &name,
                        format!("must be a list of numbers, got {x:?}"),
                    ));
                }
                (Kind::Number(_), Value::Number(_)) => {}
            }
            values[i] = Some(value);
        }
        let values = info
            .parameters
            .iter()
            .zip(values)
            .map(|(p, v)| match (v, p.kind) {
                (Some(v), _) => Ok(v),
                (None, Kind::Number(Some(x))) => Ok(Value::Number(x)),
                (None, Kind::List(Some(xs))) => Ok(Value::List(xs.to_vec())),
                (None, Kind::Number(None)) => Err(argument_error(
                    scene,
                    p.name,
                    "missing, and it has no default: give a real number".into(),
                )),
                (None, Kind::List(None)) => Err(argument_error(
                    scene,
                    p.name,
                    "missing, and it has no default: give a list of numbers".into(),
                )),
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(Self { info, values })
    }

    /// The scene these arguments are for.
    pub fn info(&self) -> &'static SceneInfo {
        self.info
    }

    /// The values in the order of the scene's parameters.
    pub fn values(&self) -> &[Value] {
        &self.values
    }

    fn value(&self, name: &str) -> &Value {
        let i = self
            .info
            .parameters
            .iter()
            .position(|p| p.name == name)
            .unwrap_or_else(|| panic!("{} has no parameter {name}", self.info.name));
        &self.values[i]
    }

    /// The number parameter `name`.
    ///
    /// # Panics
    /// If the scene declares no number parameter `name` (a bug in the scene's declaration).
    pub fn number(&self, name: &str) -> f64 {
        match self.value(name) {
            Value::Number(x) => *x,
            Value::List(_) => panic!("{}: {name} is a list", self.info.name),
        }
    }

    /// The list parameter `name`.
    ///
    /// # Panics
    /// If the scene declares no list parameter `name` (a bug in the scene's declaration).
    pub fn list(&self, name: &str) -> &[f64] {
        match self.value(name) {
            Value::List(xs) => xs,
            Value::Number(_) => panic!("{}: {name} is a number", self.info.name),
        }
    }
}

/// What to draw besides the particles, which are referred to by their index in the scene's
/// [`Particles::positions`]; index −1 is the pivot.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Drawing {
    /// Segments between two particles (or a particle and the pivot).
    pub rods: Vec<(i64, i64)>,
    /// Whether the pivot moves ([`Scene::pivot`]); otherwise it is the origin.
    pub moving_pivot: bool,
    /// Rolling bodies as (centre, rim point, opposite rim point).
    pub bodies: Vec<[usize; 3]>,
    /// Fixed circles (x, y, radius).
    pub circles: Vec<[f64; 3]>,
    /// Fixed lines through (x, y) along (dx, dy).
    pub lines: Vec<[f64; 4]>,
    /// Fixed points (x, y).
    pub marks: Vec<[f64; 2]>,
    /// The particles that leave a trail; `None` for every particle that is not a rim point.
    pub trail: Option<Vec<usize>>,
}

impl Drawing {
    /// A pendulum chain of `links` bobs: rods from the pivot through the bobs, the last bob
    /// trailed, the pivot marked unless it moves.
    pub fn chain(links: usize, moving_pivot: bool) -> Self {
        let links = links as i64;
        Self {
            rods: (0..links).map(|k| (k - 1, k)).collect(),
            moving_pivot,
            marks: if moving_pivot {
                vec![]
            } else {
                vec![[0.0, 0.0]]
            },
            trail: Some(vec![(links - 1).max(0) as usize]),
            ..Self::default()
        }
    }
}

/// The states (q, q̇) of an exact solution.
pub type State = (Vec<f64>, Vec<f64>);

/// [`Scene::exact`] from a closed form in two coordinates that takes and gives arrays.
///
/// # Errors
/// Those of `closed_form`.
pub fn exact_planar(
    q0: &[f64],
    qd0: &[f64],
    closed_form: impl FnOnce([f64; 2], [f64; 2]) -> Result<[[f64; 2]; 2]>,
) -> Result<State> {
    let [q, qd] = closed_form([q0[0], q0[1]], [qd0[0], qd0[1]])?;
    Ok((q.to_vec(), qd.to_vec()))
}

/// A ready-made system declared for the catalog: implemented by each scene's parameter struct.
pub trait Scene {
    /// The system the scene's arguments build.
    /// Every scene's system can be traced ([`TraceEnergies`]) for the methods that need the
    /// expression graph (Taylor).
    type System: Dynamics + Drawn + TraceEnergies;

    /// The catalog entry.
    const INFO: SceneInfo;

    /// The system for these (checked) arguments.
    ///
    /// # Errors
    /// [`Error::SceneArgument`] when the values are of the right kinds but do not go together
    /// (lists of different lengths).
    fn build(args: &Arguments) -> Result<Self::System>;

    /// How to draw the scene beyond points with trails; `None` for points with trails.
    fn drawing(_args: &Arguments) -> Option<Drawing> {
        None
    }

    /// The pivot at time `t`, when [`Drawing::moving_pivot`].
    fn pivot(_args: &Arguments, _t: f64) -> [f64; 2] {
        [0.0, 0.0]
    }

    /// The exact state at time `t` from (`q0`, `qd0`) at t = 0, when [`SceneInfo::exact`].
    ///
    /// # Errors
    /// [`Error::InvalidInput`] when the scene has no exact solution, or none for these
    /// parameters or this state (resonance, an unbound orbit).
    fn exact(_args: &Arguments, _q0: &[f64], _qd0: &[f64], _t: f64) -> Result<State> {
        Err(no_exact(Self::INFO.name))
    }
}

fn no_exact(scene: &str) -> Error {
    Error::InvalidInput {
        what: "exact solution",
        why: format!("the scene {scene} has no exact solution; simulate it instead"),
    }
}

/// Particle positions of many states: (particles, dimension, values state after state).
pub type Positions = (usize, usize, Vec<f64>);

/// A system that can say where its particles are: every particle-route system, and every
/// energy-route system whose kinetic energy is that of [`Particles`]; the others (a scene stated
/// by its energies only) implement it with `None`.
pub trait Drawn {
    /// The particles' positions at the states (t_i, q_i) (`q` row after row), or `None`.
    fn positions(&self, t: &[f64], q: &[f64]) -> Option<Positions>;
}

impl<P: Particles, U, R, Q, F> Drawn for ParticleSystem<P, U, R, Q, F> {
    fn positions(&self, t: &[f64], q: &[f64]) -> Option<Positions> {
        Some(positions_of(&self.particles, t, q))
    }
}

impl<K: Particles, U, R, Q> Drawn for System<K, U, R, Q> {
    fn positions(&self, t: &[f64], q: &[f64]) -> Option<Positions> {
        Some(positions_of(&self.kinetic, t, q))
    }
}

/// The bodies' centres of mass, drawn as points.
impl<B: RigidBodies, U, R, Q> Drawn for BodySystem<B, U, R, Q> {
    fn positions(&self, t: &[f64], q: &[f64]) -> Option<Positions> {
        let (b, n) = (&self.bodies, self.bodies.dof());
        let count = b.count();
        let mut poses = vec![Pose::identity(); count];
        let mut r = Vec::with_capacity(t.len() * count * 3);
        for (i, &ti) in t.iter().enumerate() {
            b.poses(ti, &q[i * n..(i + 1) * n], &mut poses);
            r.extend(poses.iter().flat_map(|p| p.centre));
        }
        Some((count, 3, r))
    }
}

/// Positions of `p` at the states (t_i, q_i), `q` row after row.
pub fn positions_of<P: Particles>(p: &P, t: &[f64], q: &[f64]) -> Positions {
    let (n, width) = (p.dof(), p.coordinates_len());
    let mut r = vec![0.0; t.len() * width];
    for (i, (&ti, out)) in t.iter().zip(r.chunks_exact_mut(width)).enumerate() {
        p.positions(ti, &q[i * n..(i + 1) * n], out);
    }
    (p.count(), p.dim(), r)
}

/// Every scene, in catalog order: calls the macro `$then!` with the scene types (each
/// implements [`Scene`]; the type name is also the Python model's variant name). The one
/// registry line of a new scene goes here.
macro_rules! scenes {
    ($then:ident) => {
        $then! {
            SimplePendulum,
            DoublePendulum,
            NPendulum,
            ForcedTwoMass,
            RollingCylinder,
            BallInSphere,
            DampedOscillator,
            Kepler,
            ElasticPendulum,
            HenonHeiles,
            DrivenPendulum,
            ChargedParticle,
            Lever,
            DifferentialPulley,
            RhombusLink,
            SpringRhombus,
            TwoSprings,
            SpatialChain,
        }
    };
}
#[cfg_attr(not(feature = "python"), allow(unused_imports))]
pub(crate) use scenes;

macro_rules! catalog_of {
    ($($scene:ident,)*) => {
        /// Every scene's catalog entry, in the order of `scenes!` (in this file).
        pub static CATALOG: &[SceneInfo] = &[$(<super::$scene as Scene>::INFO,)*];

        /// What the registry can do with a scene known only by name.
        fn dispatch(args: &Arguments, job: Job<'_>) -> Result<Done> {
            let name = args.info().name;
            $(
                if name == <super::$scene as Scene>::INFO.name {
                    type S = super::$scene;
                    return Ok(match job {
                        Job::Drawing => Done::Drawing(<S as Scene>::drawing(args)),
                        Job::Pivot(t) => Done::Pivot(
                            t.iter().map(|&t| <S as Scene>::pivot(args, t)).collect(),
                        ),
                        Job::Exact(q0, qd0, t) => {
                            Done::Exact(<S as Scene>::exact(args, q0, qd0, t)?)
                        }
                    });
                }
            )*
            Err(unknown(name))
        }
    };
}
scenes!(catalog_of);

enum Job<'a> {
    Drawing,
    Pivot(&'a [f64]),
    Exact(&'a [f64], &'a [f64], f64),
}

enum Done {
    Drawing(Option<Drawing>),
    Pivot(Vec<[f64; 2]>),
    Exact(State),
}

fn unknown(name: &str) -> Error {
    Error::InvalidInput {
        what: "scene",
        why: format!(
            "unknown scene {name:?}; the scenes are {}",
            CATALOG
                .iter()
                .map(|s| s.name)
                .collect::<Vec<_>>()
                .join(", ")
        ),
    }
}

/// Every scene's catalog entry.
pub fn catalog() -> &'static [SceneInfo] {
    CATALOG
}

/// The catalog entry of the scene `name`.
///
/// # Errors
/// [`Error::InvalidInput`] for an unknown scene.
pub fn info(name: &str) -> Result<&'static SceneInfo> {
    CATALOG
        .iter()
        .find(|s| s.name == name)
        .ok_or_else(|| unknown(name))
}

/// How to draw the scene of these arguments (see [`Scene::drawing`]).
pub fn drawing(args: &Arguments) -> Option<Drawing> {
    match dispatch(args, Job::Drawing) {
        Ok(Done::Drawing(d)) => d,
        _ => None,
    }
}

/// The pivot of the scene of these arguments at the times `t` (see [`Scene::pivot`]).
pub fn pivot(args: &Arguments, t: &[f64]) -> Vec<[f64; 2]> {
    match dispatch(args, Job::Pivot(t)) {
        Ok(Done::Pivot(p)) => p,
        _ => vec![[0.0, 0.0]; t.len()],
    }
}

/// The exact state at time `t` of the scene of these arguments from (`q0`, `qd0`) at t = 0.
///
/// # Errors
/// [`Error::DimensionMismatch`] for states of the wrong size, [`Error::InvalidInput`] for
/// non-finite input or a scene without an exact solution (see [`Scene::exact`]).
pub fn exact(args: &Arguments, q0: &[f64], qd0: &[f64], t: f64) -> Result<State> {
    let n = args.info().coordinate_names(args).len();
    for (what, v) in [("q0", q0), ("qd0", qd0)] {
        if v.len() != n {
            return Err(Error::DimensionMismatch {
                what,
                expected: n,
                got: v.len(),
            });
        }
    }
    if !(t.is_finite() && q0.iter().chain(qd0).all(|x| x.is_finite())) {
        return Err(Error::InvalidInput {
            what: "exact solution",
            why: format!("t = {t}, q0 = {q0:?} and qd0 = {qd0:?} must be finite"),
        });
    }
    match dispatch(args, Job::Exact(q0, qd0, t))? {
        Done::Exact(s) => Ok(s),
        _ => Err(no_exact(args.info().name)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn given(pairs: &[(&str, Value)]) -> Vec<(String, Value)> {
        pairs
            .iter()
            .map(|(k, v)| (k.to_string(), v.clone()))
            .collect()
    }

    static REQUIRED: SceneInfo = SceneInfo {
        name: "required",
        doc: "A test entry with a parameter without default.",
        parameters: &[
            Parameter {
                name: "m",
                kind: Kind::Number(None),
                doc: "mass",
            },
            Parameter::number("g", 9.81, "gravity"),
        ],
        coordinates: Coordinates::Fixed(&["x"]),
        route: Route::Energy,
        exact: false,
    };

    fn parameter_of(e: Error) -> String {
        match e {
            Error::SceneArgument { parameter, .. } => parameter,
            other => panic!("not a scene argument error: {other}"),
        }
    }

    #[test]
    fn new_missing_without_default_names_parameter() {
        let e = Arguments::new(&REQUIRED, given(&[("g", Value::Number(1.0))])).unwrap_err();
        assert!(
            e.to_string()
                .ends_with("m: missing, and it has no default: give a real number"),
            "{e}"
        );
        assert_eq!(parameter_of(e), "m");
        let ok = Arguments::new(&REQUIRED, given(&[("m", Value::Number(2.0))])).unwrap();
        assert_eq!((ok.number("m"), ok.number("g")), (2.0, 9.81));
    }

    #[test]
    fn new_unknown_repeated_nonfinite_wrong_kind_name_parameter() {
        let info = info("n_pendulum").unwrap();
        let cases = [
            (
                given(&[("mass", Value::Number(1.0))]),
                "mass",
                "mass: unknown parameter; the parameters are masses, lengths, g",
            ),
            (
                given(&[("g", Value::Number(1.0)), ("g", Value::Number(2.0))]),
                "g",
                "g: given twice: give it once",
            ),
            (
                given(&[("g", Value::Number(f64::NAN))]),
                "g",
                "g: the value NaN is not finite: give a finite number",
            ),
            (
                given(&[("lengths", Value::List(vec![1.0, f64::INFINITY]))]),
                "lengths",
                "lengths: entry 1 of [1.0, inf] is inf, not finite: give finite numbers",
            ),
            (
                given(&[("masses", Value::Number(5.0))]),
                "masses",
                "masses: must be a list of numbers, got 5.0",
            ),
            (
                given(&[("g", Value::List(vec![1.0]))]),
                "g",
                "g: must be a real number, got the list [1.0]",
            ),
        ];
        for (args, name, why) in cases {
            let e = Arguments::new(info, args).unwrap_err();
            assert!(e.to_string().ends_with(why), "{e}");
            assert!(e.to_string().contains(name), "{e}");
            assert_eq!(parameter_of(e), name);
        }
    }

    #[test]
    fn catalog_names_unique_and_defaults_build() {
        let mut names: Vec<&str> = catalog().iter().map(|s| s.name).collect();
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), catalog().len());
        for s in catalog() {
            let args = Arguments::new(s, vec![]).unwrap();
            let n = s.coordinate_names(&args).len();
            assert!(n >= 1, "{}", s.name);
            assert!(!s.doc.is_empty());
            // Not radial, so that Kepler's orbit has angular momentum.
            let q0 = vec![0.1; n];
            let qd0: Vec<f64> = (0..n).map(|i| [0.2, -0.1][i % 2]).collect();
            assert_eq!(exact(&args, &q0, &qd0, 0.0).is_ok(), s.exact, "{}", s.name);
        }
    }

    #[test]
    fn info_unknown_scene_lists_scenes() {
        let e = info("nope").unwrap_err().to_string();
        assert!(e.contains("double_pendulum"), "{e}");
    }

    #[test]
    fn exact_kepler_from_any_state_follows_the_orbit() {
        // From the state at time s on the periapsis orbit, turned by φ (and mirrored), the exact
        // solution at t is the orbit's state at s + t, turned (and mirrored) the same way.
        let k = super::super::Kepler::new(1.0, 1.3);
        let (a, e, s) = (1.2, 0.6, 0.7);
        let (phi_s, phi_c) = 0.9f64.sin_cos();
        for mirror in [1.0, -1.0] {
            let turn = |p: [f64; 2]| {
                let y = mirror * p[1];
                [phi_c * p[0] - phi_s * y, phi_s * p[0] + phi_c * y]
            };
            let (q0, v0) = k.exact_state(a, e, s).unwrap();
            for t in [0.0, 0.4, 3.0, -2.0] {
                let (q, v) = k.exact_from(turn(q0), turn(v0), t).unwrap();
                let (wq, wv) = k.exact_state(a, e, s + t).unwrap();
                for (x, w) in q.iter().chain(&v).zip(turn(wq).iter().chain(&turn(wv))) {
                    assert!(
                        (x - w).abs() < 1e-12,
                        "{x} vs {w} (t = {t}, mirror {mirror})"
                    );
                }
            }
        }
        // A circular orbit: constant speed on the circle through q0.
        let (q, v) = k
            .exact_from([0.0, 2.0], [-(1.3f64 / 2.0).sqrt(), 0.0], 1.0)
            .unwrap();
        assert!((q[0].hypot(q[1]) - 2.0).abs() < 1e-14);
        assert!((v[0].hypot(v[1]) - (1.3f64 / 2.0).sqrt()).abs() < 1e-14);
        assert!(k.exact_from([1.0, 0.0], [2.0, 0.0], 1.0).is_err(), "radial");
        assert!(
            k.exact_from([1.0, 0.0], [0.0, 2.0], 1.0).is_err(),
            "unbound"
        );
    }

    #[test]
    fn chain_rods_from_pivot() {
        let d = Drawing::chain(3, false);
        assert_eq!(d.rods, vec![(-1, 0), (0, 1), (1, 2)]);
        assert_eq!(d.trail, Some(vec![2]));
        assert_eq!(d.marks, vec![[0.0, 0.0]]);
        assert!(Drawing::chain(1, true).marks.is_empty());
    }
}
