//! Butcher tableaux of the explicit Runge–Kutta methods, with their error estimators, dense
//! output and stiffness tests. Coefficients stay `f64`; each named constructor cites its source.
//!
//! Stage numbering: stages `0..s` are the tableau's; the driver stores f(t + h, y₁) as stage
//! `s` (for a FSAL tableau it is a copy of stage `s − 1`), and dense output appends its extra
//! stages after it. Dense-output rows and extra-stage rows index that extended list.

/// How the local error of a step is estimated.
#[derive(Debug, Clone, PartialEq)]
pub enum ErrorEstimate {
    /// An embedded pair: err = h Σ eⱼ kⱼ with e = b − b̂, b̂ of order `order`.
    Embedded {
        /// Weights e = b − b̂ over the `s` stages.
        e: Vec<f64>,
        /// Order of the embedded solution b̂.
        order: usize,
    },
    /// Hairer's DOP853 estimator: a 5th-order difference `e5` divided by a blend with a
    /// 3rd-order one `e3`, err = |h| ‖e5‖² / √(‖e5‖² + 0.01 ‖e3‖²) (Hairer, Nørsett & Wanner,
    /// *Solving ODEs I*, 2nd ed., §II.10), which is ≈ h‖e5‖ when the step is resolved but
    /// behaves like an 8th-order estimate in the step-size control.
    Dop853 {
        /// b − b̂₅ over the `s` stages.
        e5: Vec<f64>,
        /// b − b̂₃ over the `s` stages.
        e3: Vec<f64>,
    },
}

/// A continuous extension y(t₀ + θh) = y₀ + θ(F₀ + (1−θ)(F₁ + θ(F₂ + (1−θ)(F₃ + …)))) with
/// F₀ = Δy, F₁ = h f₀ − Δy, F₂ = 2Δy − h(f₀ + f₁) and F₃₊ᵣ = h Σⱼ d_rj kⱼ (Hairer's `CONTD5`
/// and `CONTD8`).
#[derive(Debug, Clone, PartialEq)]
pub struct DenseOutput {
    /// Nodes of the extra stages.
    pub c: Vec<f64>,
    /// Rows of the extra stages over the extended stage list (stage `s` is f(t + h, y₁)).
    pub a: Vec<Vec<f64>>,
    /// Rows d_r over the extended stage list.
    pub d: Vec<Vec<f64>>,
    /// Order of the interpolant.
    pub order: usize,
}

/// Hairer's stiffness test: with stage `stage` evaluated at c = 1, the ratio
/// h‖f(y₁) − kₛₜₐ₉ₑ‖ / ‖y₁ − yₛₜₐ₉ₑ‖ estimates h|λ| of the dominant eigenvalue; when it exceeds
/// `bound` (the edge of the stability region) 15 times before 6 tests fall below, the step
/// size is limited by stability, not accuracy: the problem is stiff for this method.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StiffnessTest {
    /// A stage with c = 1 whose argument and derivative are compared with y₁ and f(y₁).
    pub stage: usize,
    /// Threshold of the estimate of h|λ|.
    pub bound: f64,
}

/// Hairer's step-size controller: h_new = h / clamp(err^α / err_old^β / safety, 1/grow,
/// 1/shrink), with Lund stabilization β.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Controller {
    /// Exponent α on the current error.
    pub alpha: f64,
    /// Exponent β on the previous accepted error (0: the plain controller).
    pub beta: f64,
    /// Smallest factor h_new / h.
    pub shrink: f64,
    /// Largest factor h_new / h.
    pub grow: f64,
    /// Safety factor.
    pub safety: f64,
}

/// An explicit Runge–Kutta method: a strictly lower triangular `a`, weights `b`, nodes `c`.
#[derive(Debug, Clone, PartialEq)]
pub struct Tableau {
    /// Name in [`Method`](super::Method) spelling.
    pub name: &'static str,
    /// Order of the propagated solution.
    pub order: usize,
    /// Row i holds a_i0 … a_i,i−1.
    pub a: Vec<Vec<f64>>,
    /// Weights.
    pub b: Vec<f64>,
    /// Nodes.
    pub c: Vec<f64>,
    /// First Same As Last: the last stage is evaluated at y₁ itself (c = 1, last row = b), so
    /// its derivative starts the next step for free.
    pub fsal: bool,
    /// Local error estimate; `None` for fixed-step methods.
    pub error: Option<ErrorEstimate>,
    /// Continuous extension; `None` falls back to quintic Hermite interpolation in q.
    pub dense: Option<DenseOutput>,
    /// Stiffness test.
    pub stiffness: Option<StiffnessTest>,
    /// Step-size controller constants (Hairer's defaults for the pair).
    pub control: Controller,
}

/// RK4's and DOPRI5's coefficients as constants: their constructors build the tableaux from
/// these, and the stepping loop reads them at compile time (`runge_kutta.rs`, `Builtin`), where
/// they fold into straight-line code as in a hand-written loop. Row i of `_A` holds a_i0 …
/// a_i,i−1.
pub(crate) const RK4_A: &[&[f64]] = &[&[], &[0.5], &[0.0, 0.5], &[0.0, 0.0, 1.0]];
pub(crate) const RK4_B: &[f64] = &[1.0 / 6.0, 1.0 / 3.0, 1.0 / 3.0, 1.0 / 6.0];
pub(crate) const RK4_C: &[f64] = &[0.0, 0.5, 0.5, 1.0];
pub(crate) const DOPRI5_A: &[&[f64]] = &[
    &[],
    &[1.0 / 5.0],
    &[3.0 / 40.0, 9.0 / 40.0],
    &[44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0],
    &[
        19372.0 / 6561.0,
        -25360.0 / 2187.0,
        64448.0 / 6561.0,
        -212.0 / 729.0,
    ],
    &[
        9017.0 / 3168.0,
        -355.0 / 33.0,
        46732.0 / 5247.0,
        49.0 / 176.0,
        -5103.0 / 18656.0,
    ],
    &[
        35.0 / 384.0,
        0.0,
        500.0 / 1113.0,
        125.0 / 192.0,
        -2187.0 / 6784.0,
        11.0 / 84.0,
    ],
];
pub(crate) const DOPRI5_B: &[f64] = &[
    35.0 / 384.0,
    0.0,
    500.0 / 1113.0,
    125.0 / 192.0,
    -2187.0 / 6784.0,
    11.0 / 84.0,
    0.0,
];
pub(crate) const DOPRI5_C: &[f64] = &[0.0, 0.2, 0.3, 0.8, 8.0 / 9.0, 1.0, 1.0];
/// DOPRI5's e = b − b̂ (b̂ of order 4).
pub(crate) const DOPRI5_E: &[f64] = &[
    71.0 / 57600.0,
    0.0,
    -71.0 / 16695.0,
    71.0 / 1920.0,
    -17253.0 / 339200.0,
    22.0 / 525.0,
    -1.0 / 40.0,
];

/// The rows of `a` as the tableau stores them.
fn rows(a: &[&[f64]]) -> Vec<Vec<f64>> {
    a.iter().map(|row| row.to_vec()).collect()
}

impl Tableau {
    /// A plain tableau (no error estimate, no dense output).
    ///
    /// # Panics
    /// If the shapes do not match, or a row of `a` does not sum to its node (the tableaux here
    /// are all built that way; it is what makes t-dependent problems come out right).
    pub fn new(
        name: &'static str,
        order: usize,
        a: Vec<Vec<f64>>,
        b: Vec<f64>,
        c: Vec<f64>,
    ) -> Self {
        let s = b.len();
        assert!(s > 0, "a tableau needs at least one stage");
        assert_eq!(a.len(), s, "one row of a per stage");
        assert_eq!(c.len(), s, "one node per stage");
        for (i, row) in a.iter().enumerate() {
            assert_eq!(
                row.len(),
                i,
                "row {i} of an explicit tableau has {i} entries"
            );
            let sum: f64 = row.iter().sum();
            let scale: f64 = 1.0 + row.iter().map(|x| x.abs()).sum::<f64>();
            assert!(
                (sum - c[i]).abs() <= 1e-14 * scale,
                "row {i} sums to {sum}, node is {}",
                c[i]
            );
        }
        Self {
            name,
            order,
            a,
            b,
            c,
            fsal: false,
            error: None,
            dense: None,
            stiffness: None,
            control: Controller {
                alpha: 1.0 / (order as f64 + 1.0),
                beta: 0.0,
                shrink: 0.2,
                grow: 10.0,
                safety: 0.9,
            },
        }
    }

    /// Number of stages.
    pub fn stages(&self) -> usize {
        self.b.len()
    }

    /// Check the shapes of the error estimate, the dense output and the stiffness test.
    fn check_extended(&self) {
        let s = self.stages();
        match &self.error {
            Some(ErrorEstimate::Embedded { e, .. }) => assert_eq!(e.len(), s),
            Some(ErrorEstimate::Dop853 { e5, e3 }) => {
                assert_eq!(e5.len(), s);
                assert_eq!(e3.len(), s);
            }
            None => {}
        }
        if let Some(dense) = &self.dense {
            assert_eq!(dense.c.len(), dense.a.len());
            for (i, row) in dense.a.iter().enumerate() {
                assert_eq!(
                    row.len(),
                    s + 1 + i,
                    "extra stage {i} reads the stages before it"
                );
            }
            for row in &dense.d {
                assert_eq!(row.len(), s + 1 + dense.c.len());
            }
        }
        if let Some(test) = self.stiffness {
            assert!(test.stage < s && self.c[test.stage] == 1.0);
        }
        if self.fsal {
            assert_eq!(self.c[s - 1], 1.0);
            assert_eq!(self.a[s - 1], self.b[..s - 1]);
            assert_eq!(self.b[s - 1], 0.0);
        }
    }

    /// The classical Runge–Kutta method of order 4 (Kutta, *Z. Math. Phys.* 46, 1901).
    pub fn rk4() -> Self {
        Self::new("rk4", 4, rows(RK4_A), RK4_B.to_vec(), RK4_C.to_vec())
    }

    /// Dormand–Prince 5(4): J. R. Dormand & P. J. Prince, "A family of embedded Runge–Kutta
    /// formulae", *J. Comput. Appl. Math.* 6 (1980) 19–26; dense output of order 4 by
    /// Shampine (1986) and the stiffness test and controller of Hairer's `dopri5.f`
    /// (Hairer, Nørsett & Wanner, *Solving ODEs I*, §II.5, §II.6, §IV.2).
    pub fn dopri5() -> Self {
        let mut t = Self::new(
            "dopri5",
            5,
            rows(DOPRI5_A),
            DOPRI5_B.to_vec(),
            DOPRI5_C.to_vec(),
        );
        t.fsal = true;
        t.error = Some(ErrorEstimate::Embedded {
            e: DOPRI5_E.to_vec(),
            order: 4,
        });
        t.dense = Some(DenseOutput {
            c: vec![],
            a: vec![],
            d: vec![vec![
                -12715105075.0 / 11282082432.0,
                0.0,
                87487479700.0 / 32700410799.0,
                -10690763975.0 / 1880347072.0,
                701980252875.0 / 199316789632.0,
                -1453857185.0 / 822651844.0,
                69997945.0 / 29380423.0,
                0.0,
            ]],
            order: 4,
        });
        t.stiffness = Some(StiffnessTest {
            stage: 5,
            bound: 3.25,
        });
        // dopri5.f: BETA = 0.04, EXPO1 = 0.2 − 0.75 BETA, FAC1 = 0.2, FAC2 = 10.
        t.control = Controller {
            alpha: 0.2 - 0.75 * 0.04,
            beta: 0.04,
            shrink: 0.2,
            grow: 10.0,
            safety: 0.9,
        };
        t.check_extended();
        t
    }

    /// DOP853: the explicit Runge–Kutta method of order 8 by Dormand & Prince ("High order
    /// embedded Runge–Kutta formulae", *J. Comput. Appl. Math.* 7 (1981) 67–75) with Hairer's
    /// 5th/3rd-order error estimator, 7th-order dense output (three extra stages), stiffness
    /// test and controller, transcribed from Hairer's `dop853.f` (Hairer, Nørsett & Wanner,
    /// *Solving ODEs I*, 2nd ed., §II.10).
    #[allow(clippy::excessive_precision)]
    pub fn dop853() -> Self {
        let a = vec![
            vec![],
            vec![0.05260015195876773],
            vec![0.0197250569845379, 0.0591751709536137],
            vec![0.02958758547680685, 0.0, 0.08876275643042054],
            vec![
                0.2413651341592667,
                0.0,
                -0.8845494793282861,
                0.924834003261792,
            ],
            vec![
                0.037037037037037035,
                0.0,
                0.0,
                0.17082860872947386,
                0.12546768756682242,
            ],
            vec![
                0.037109375,
                0.0,
                0.0,
                0.17025221101954405,
                0.06021653898045596,
                -0.017578125,
            ],
            vec![
                0.03709200011850479,
                0.0,
                0.0,
                0.17038392571223998,
                0.10726203044637328,
                -0.015319437748624402,
                0.008273789163814023,
            ],
            vec![
                0.6241109587160757,
                0.0,
                0.0,
                -3.3608926294469414,
                -0.868219346841726,
                27.59209969944671,
                20.154067550477894,
                -43.48988418106996,
            ],
            vec![
                0.47766253643826434,
                0.0,
                0.0,
                -2.4881146199716677,
                -0.590290826836843,
                21.230051448181193,
                15.279233632882423,
                -33.28821096898486,
                -0.020331201708508627,
            ],
            vec![
                -0.9371424300859873,
                0.0,
                0.0,
                5.186372428844064,
                1.0914373489967295,
                -8.149787010746927,
                -18.52006565999696,
                22.739487099350505,
                2.4936055526796523,
                -3.0467644718982196,
            ],
            vec![
                2.273310147516538,
                0.0,
                0.0,
                -10.53449546673725,
                -2.0008720582248625,
                -17.9589318631188,
                27.94888452941996,
                -2.8589982771350235,
                -8.87285693353063,
                12.360567175794303,
                0.6433927460157636,
            ],
        ];
        let b = vec![
            0.054293734116568765,
            0.0,
            0.0,
            0.0,
            0.0,
            4.450312892752409,
            1.8915178993145003,
            -5.801203960010585,
            0.3111643669578199,
            -0.1521609496625161,
            0.20136540080403034,
            0.04471061572777259,
        ];
        let c = vec![
            0.0,
            0.05260015195876773,
            0.0789002279381516,
            0.1183503419072274,
            0.2816496580927726,
            1.0 / 3.0,
            0.25,
            4.0 / 13.0,
            127.0 / 195.0,
            0.6,
            6.0 / 7.0,
            1.0,
        ];
        // e3 = b − b̂₃ with b̂₃ = (BHH1, BHH2, BHH3) on stages 1, 9, 12.
        let mut e3 = b.clone();
        e3[0] -= 0.2440944881889764;
        e3[8] -= 0.7338466882816118;
        e3[11] -= 0.022058823529411766;
        let e5 = vec![
            0.01312004499419488,
            0.0,
            0.0,
            0.0,
            0.0,
            -1.2251564463762044,
            -0.4957589496572502,
            1.6643771824549864,
            -0.35032884874997366,
            0.3341791187130175,
            0.08192320648511571,
            -0.022355307863886294,
        ];
        let dense = DenseOutput {
            c: vec![0.1, 0.2, 7.0 / 9.0],
            a: vec![
                vec![
                    0.056167502283047954,
                    0.0,
                    0.0,
                    0.0,
                    0.0,
                    0.0,
                    0.25350021021662483,
                    -0.2462390374708025,
                    -0.12419142326381637,
                    0.15329179827876568,
                    0.00820105229563469,
                    0.007567897660545699,
                    -0.008298,
                ],
                vec![
                    0.03183464816350214,
                    0.0,
                    0.0,
                    0.0,
                    0.0,
                    0.028300909672366776,
                    0.053541988307438566,
                    -0.05492374857139099,
                    0.0,
                    0.0,
                    -0.00010834732869724932,
                    0.0003825710908356584,
                    -0.00034046500868740456,
                    0.1413124436746325,
                ],
                vec![
                    -0.42889630158379194,
                    0.0,
                    0.0,
                    0.0,
                    0.0,
                    -4.697621415361164,
                    7.683421196062599,
                    4.06898981839711,
                    0.3567271874552811,
                    0.0,
                    0.0,
                    0.0,
                    -0.0013990241651590145,
                    2.9475147891527724,
                    -9.15095847217987,
                ],
            ],
            d: vec![
                vec![
                    -8.428938276109013,
                    0.0,
                    0.0,
                    0.0,
                    0.0,
                    0.5667149535193777,
                    -3.0689499459498917,
                    2.38466765651207,
                    2.117034582445028,
                    -0.871391583777973,
                    2.2404374302607883,
                    0.6315787787694688,
                    -0.08899033645133331,
                    18.148505520854727,
                    -9.194632392478356,
                    -4.436036387594894,
                ],
                vec![
                    10.427508642579134,
                    0.0,
                    0.0,
                    0.0,
                    0.0,
                    242.28349177525817,
                    165.20045171727028,
                    -374.5467547226902,
                    -22.113666853125306,
                    7.733432668472264,
                    -30.674084731089398,
                    -9.332130526430229,
                    15.697238121770845,
                    -31.139403219565178,
                    -9.35292435884448,
                    35.81684148639408,
                ],
                vec![
                    19.985053242002433,
                    0.0,
                    0.0,
                    0.0,
                    0.0,
                    -387.0373087493518,
                    -189.17813819516758,
                    527.8081592054236,
                    -11.57390253995963,
                    6.8812326946963,
                    -1.0006050966910838,
                    0.7777137798053443,
                    -2.778205752353508,
                    -60.19669523126412,
                    84.32040550667716,
                    11.99229113618279,
                ],
                vec![
                    -25.69393346270375,
                    0.0,
                    0.0,
                    0.0,
                    0.0,
                    -154.18974869023643,
                    -231.5293791760455,
                    357.6391179106141,
                    93.40532418362432,
                    -37.45832313645163,
                    104.0996495089623,
                    29.8402934266605,
                    -43.53345659001114,
                    96.32455395918828,
                    -39.17726167561544,
                    -149.72683625798564,
                ],
            ],
            order: 7,
        };
        let mut t = Self::new("dop853", 8, a, b, c);
        t.error = Some(ErrorEstimate::Dop853 { e5, e3 });
        t.dense = Some(dense);
        t.stiffness = Some(StiffnessTest {
            stage: 11,
            bound: 6.1,
        });
        // dop853.f: BETA = 0, EXPO1 = 1/8, FAC1 = 0.333, FAC2 = 6.
        t.control = Controller {
            alpha: 1.0 / 8.0,
            beta: 0.0,
            shrink: 0.333,
            grow: 6.0,
            safety: 0.9,
        };
        t.check_extended();
        t
    }
}
