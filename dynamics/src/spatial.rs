//! Spatial algebra: rigid transforms, motion and force vectors, rigid-body inertias.
//!
//! Conventions (the same as Pinocchio's, Featherstone's with the linear part first):
//!
//! * [`Se3`] `aMb = (R, p)` maps coordinates in frame *b* to frame *a*: `x_a = R x_b + p`.
//! * [`Motion`] `(v, ω)`: linear velocity of the point at the frame origin, then angular
//!   velocity, both expressed in the frame.
//! * [`Force`] `(f, n)`: force, then moment about the frame origin.
//! * [`Inertia`] `(m, c, I_c)`: mass, centre of mass in the frame, rotational inertia about
//!   the centre of mass in the frame's axes.
//!
//! Everything here is `Copy` and fixed-size; nothing allocates.

use nalgebra::{Matrix3, Matrix6, Rotation3, UnitQuaternion, Vector3, Vector6};

/// The skew-symmetric matrix `[a]ₓ` with `[a]ₓ b = a × b`.
#[inline]
pub fn skew(a: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -a.z, a.y, a.z, 0.0, -a.x, -a.y, a.x, 0.0)
}

/// `R S Rᵀ` for a symmetric `S`, computing only the upper triangle of the product.
#[inline]
pub fn rotate_symmetric(r: &Matrix3<f64>, s: &Matrix3<f64>) -> Matrix3<f64> {
    let t = r * s;
    let e = |i: usize, j: usize| t[(i, 0)] * r[(j, 0)] + t[(i, 1)] * r[(j, 1)] + t[(i, 2)] * r[(j, 2)];
    let (a, b, c, d, f, g) = (e(0, 0), e(0, 1), e(0, 2), e(1, 1), e(1, 2), e(2, 2));
    Matrix3::new(a, b, c, b, d, f, c, f, g)
}

/// Adds to the symmetric `s` the symmetric matrix with diagonal `diag` and off-diagonal
/// entries `−off` = `−(xy, xz, yz)`: the shape of every parallel-axis correction.
#[inline]
fn add_symmetric(s: &mut Matrix3<f64>, diag: [f64; 3], off: [f64; 3]) {
    for (k, d) in diag.into_iter().enumerate() {
        s[(k, k)] += d;
    }
    for ((r, c), o) in [(0, 1), (0, 2), (1, 2)].into_iter().zip(off) {
        s[(r, c)] -= o;
        s[(c, r)] -= o;
    }
}

/// A rigid transform `aMb = (R, p)`: `x_a = R x_b + p`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Se3 {
    /// Rotation `R` (columns are the axes of frame *b* in frame *a*).
    pub rotation: Matrix3<f64>,
    /// Translation `p`: the origin of frame *b* in frame *a*.
    pub translation: Vector3<f64>,
}

impl Default for Se3 {
    fn default() -> Self {
        Self::identity()
    }
}

impl Se3 {
    /// The identity transform.
    #[inline]
    pub fn identity() -> Self {
        Self { rotation: Matrix3::identity(), translation: Vector3::zeros() }
    }

    /// Builds a transform from a rotation matrix and a translation.
    #[inline]
    pub fn new(rotation: Matrix3<f64>, translation: Vector3<f64>) -> Self {
        Self { rotation, translation }
    }

    /// A pure translation.
    #[inline]
    pub fn from_translation(translation: Vector3<f64>) -> Self {
        Self { rotation: Matrix3::identity(), translation }
    }

    /// Builds a transform from a unit quaternion and a translation.
    #[inline]
    pub fn from_quaternion(q: &UnitQuaternion<f64>, translation: Vector3<f64>) -> Self {
        Self { rotation: q.to_rotation_matrix().into_inner(), translation }
    }

    /// URDF `<origin xyz rpy>`: `R = Rz(yaw) · Ry(pitch) · Rx(roll)` (fixed-axis X, Y, Z).
    pub fn from_xyz_rpy(xyz: [f64; 3], rpy: [f64; 3]) -> Self {
        let rotation = Rotation3::from_euler_angles(rpy[0], rpy[1], rpy[2]).into_inner();
        Self { rotation, translation: Vector3::from(xyz) }
    }

    /// The rotation as a unit quaternion (closed form; `rotation` must be orthonormal).
    pub fn quaternion(&self) -> UnitQuaternion<f64> {
        UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(self.rotation))
    }

    /// Composition `aMc = aMb · bMc`.
    #[inline]
    pub fn mul(&self, other: &Se3) -> Se3 {
        Se3 {
            rotation: self.rotation * other.rotation,
            translation: self.rotation * other.translation + self.translation,
        }
    }

    /// The inverse `bMa`.
    #[inline]
    pub fn inverse(&self) -> Se3 {
        let rt = self.rotation.transpose();
        Se3 { rotation: rt, translation: -(rt * self.translation) }
    }

    /// `aMb⁻¹ · aMc = bMc`, without forming the inverse.
    #[inline]
    pub fn inv_mul(&self, other: &Se3) -> Se3 {
        let rt = self.rotation.transpose();
        Se3 { rotation: rt * other.rotation, translation: rt * (other.translation - self.translation) }
    }

    /// Maps a point from frame *b* to frame *a*.
    #[inline]
    pub fn act_point(&self, x: &Vector3<f64>) -> Vector3<f64> {
        self.rotation * x + self.translation
    }

    /// Maps a point from frame *a* to frame *b*.
    #[inline]
    pub fn act_inv_point(&self, x: &Vector3<f64>) -> Vector3<f64> {
        self.rotation.tr_mul(&(x - self.translation))
    }

    /// Expresses in frame *a* a motion given in frame *b*:
    /// `ω_a = R ω_b`, `v_a = R v_b + p × ω_a`.
    #[inline]
    pub fn act_motion(&self, m: &Motion) -> Motion {
        let angular = self.rotation * m.angular;
        Motion { linear: self.rotation * m.linear + self.translation.cross(&angular), angular }
    }

    /// Expresses in frame *b* a motion given in frame *a*:
    /// `ω_b = Rᵀ ω_a`, `v_b = Rᵀ (v_a − p × ω_a)`.
    #[inline]
    pub fn act_inv_motion(&self, m: &Motion) -> Motion {
        Motion {
            linear: self.rotation.tr_mul(&(m.linear - self.translation.cross(&m.angular))),
            angular: self.rotation.tr_mul(&m.angular),
        }
    }

    /// Expresses in frame *a* a force given in frame *b*:
    /// `f_a = R f_b`, `n_a = R n_b + p × f_a`.
    #[inline]
    pub fn act_force(&self, f: &Force) -> Force {
        let linear = self.rotation * f.linear;
        Force { linear, angular: self.rotation * f.angular + self.translation.cross(&linear) }
    }

    /// Expresses in frame *b* a force given in frame *a*:
    /// `f_b = Rᵀ f_a`, `n_b = Rᵀ (n_a − p × f_a)`.
    #[inline]
    pub fn act_inv_force(&self, f: &Force) -> Force {
        Force {
            linear: self.rotation.tr_mul(&f.linear),
            angular: self.rotation.tr_mul(&(f.angular - self.translation.cross(&f.linear))),
        }
    }

    /// Expresses in frame *a* an inertia given in frame *b*.
    #[inline]
    pub fn act_inertia(&self, y: &Inertia) -> Inertia {
        Inertia {
            mass: y.mass,
            lever: self.act_point(&y.lever),
            rotational: self.rotation * y.rotational * self.rotation.transpose(),
        }
    }

    /// The 6×6 matrix `X` with `act_motion(m) = X · m` (`[v; ω]` ordering).
    pub fn motion_matrix(&self) -> Matrix6<f64> {
        let mut x = Matrix6::zeros();
        x.fixed_view_mut::<3, 3>(0, 0).copy_from(&self.rotation);
        x.fixed_view_mut::<3, 3>(3, 3).copy_from(&self.rotation);
        x.fixed_view_mut::<3, 3>(0, 3).copy_from(&(skew(&self.translation) * self.rotation));
        x
    }

    /// Congruence transform of a 6×6 spatial inertia (or articulated-body inertia) given in
    /// frame *b* into frame *a*: `Y_a = X* Y_b X⁻¹` where `X*` is the force transform.
    ///
    /// With `Y = [[A, B], [Bᵀ, C]]` and `T = [p]ₓ`, after rotating each block by `R`:
    /// `A_a = A`, `B_a = B − A T`, `C_a = C + T B + (T B)ᵀ − T A T`.
    #[inline]
    pub fn act_matrix6(&self, y: &Matrix6<f64>) -> Matrix6<f64> {
        let r = &self.rotation;
        let a = r * y.fixed_view::<3, 3>(0, 0) * r.transpose();
        let b = r * y.fixed_view::<3, 3>(0, 3) * r.transpose();
        let c = r * y.fixed_view::<3, 3>(3, 3) * r.transpose();
        let t = skew(&self.translation);
        let at = a * t;
        let tb = t * b;
        let b_a = b - at;
        let c_a = c + tb + tb.transpose() - t * at;
        let mut out = Matrix6::zeros();
        out.fixed_view_mut::<3, 3>(0, 0).copy_from(&a);
        out.fixed_view_mut::<3, 3>(0, 3).copy_from(&b_a);
        out.fixed_view_mut::<3, 3>(3, 0).copy_from(&b_a.transpose());
        out.fixed_view_mut::<3, 3>(3, 3).copy_from(&c_a);
        out
    }
}

/// A spatial motion vector (twist or spatial acceleration) `(v, ω)`.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Motion {
    /// Linear part `v` (velocity of the point at the frame origin).
    pub linear: Vector3<f64>,
    /// Angular part `ω`.
    pub angular: Vector3<f64>,
}

impl Motion {
    /// The zero motion.
    #[inline]
    pub fn zero() -> Self {
        Self { linear: Vector3::zeros(), angular: Vector3::zeros() }
    }

    /// Builds a motion from its linear and angular parts.
    #[inline]
    pub fn new(linear: Vector3<f64>, angular: Vector3<f64>) -> Self {
        Self { linear, angular }
    }

    /// From a 6-vector `[v; ω]`.
    #[inline]
    pub fn from_vector(x: &Vector6<f64>) -> Self {
        Self { linear: x.fixed_rows::<3>(0).into_owned(), angular: x.fixed_rows::<3>(3).into_owned() }
    }

    /// As a 6-vector `[v; ω]`.
    #[inline]
    pub fn to_vector(&self) -> Vector6<f64> {
        Vector6::new(
            self.linear.x,
            self.linear.y,
            self.linear.z,
            self.angular.x,
            self.angular.y,
            self.angular.z,
        )
    }

    /// Spatial cross product of motions `m₁ × m₂ = (ω₁ × v₂ + v₁ × ω₂, ω₁ × ω₂)`.
    #[inline]
    pub fn cross(&self, m: &Motion) -> Motion {
        Motion {
            linear: self.angular.cross(&m.linear) + self.linear.cross(&m.angular),
            angular: self.angular.cross(&m.angular),
        }
    }

    /// Dual cross product `m ×* f = (ω × f, ω × n + v × f)`.
    #[inline]
    pub fn cross_force(&self, f: &Force) -> Force {
        Force {
            linear: self.angular.cross(&f.linear),
            angular: self.angular.cross(&f.angular) + self.linear.cross(&f.linear),
        }
    }

    /// Power pairing `m · f = v·f + ω·n`.
    #[inline]
    pub fn dot(&self, f: &Force) -> f64 {
        self.linear.dot(&f.linear) + self.angular.dot(&f.angular)
    }

    /// Scales both parts.
    #[inline]
    pub fn scale(&self, s: f64) -> Motion {
        Motion { linear: self.linear * s, angular: self.angular * s }
    }
}

impl std::ops::Add for Motion {
    type Output = Motion;
    #[inline]
    fn add(self, m: Motion) -> Motion {
        Motion { linear: self.linear + m.linear, angular: self.angular + m.angular }
    }
}

impl std::ops::Sub for Motion {
    type Output = Motion;
    #[inline]
    fn sub(self, m: Motion) -> Motion {
        Motion { linear: self.linear - m.linear, angular: self.angular - m.angular }
    }
}

impl std::ops::AddAssign for Motion {
    #[inline]
    fn add_assign(&mut self, m: Motion) {
        self.linear += m.linear;
        self.angular += m.angular;
    }
}

impl std::ops::Neg for Motion {
    type Output = Motion;
    #[inline]
    fn neg(self) -> Motion {
        Motion { linear: -self.linear, angular: -self.angular }
    }
}

/// A spatial force vector (wrench or momentum) `(f, n)`, moment about the frame origin.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Force {
    /// Linear part: force (or linear momentum).
    pub linear: Vector3<f64>,
    /// Angular part: moment about the frame origin (or angular momentum).
    pub angular: Vector3<f64>,
}

impl Force {
    /// The zero force.
    #[inline]
    pub fn zero() -> Self {
        Self { linear: Vector3::zeros(), angular: Vector3::zeros() }
    }

    /// Builds a force from its linear and angular parts.
    #[inline]
    pub fn new(linear: Vector3<f64>, angular: Vector3<f64>) -> Self {
        Self { linear, angular }
    }

    /// As a 6-vector `[f; n]`.
    #[inline]
    pub fn to_vector(&self) -> Vector6<f64> {
        Vector6::new(
            self.linear.x,
            self.linear.y,
            self.linear.z,
            self.angular.x,
            self.angular.y,
            self.angular.z,
        )
    }

    /// From a 6-vector `[f; n]`.
    #[inline]
    pub fn from_vector(x: &Vector6<f64>) -> Self {
        Self { linear: x.fixed_rows::<3>(0).into_owned(), angular: x.fixed_rows::<3>(3).into_owned() }
    }
}

impl std::ops::Add for Force {
    type Output = Force;
    #[inline]
    fn add(self, f: Force) -> Force {
        Force { linear: self.linear + f.linear, angular: self.angular + f.angular }
    }
}

impl std::ops::Sub for Force {
    type Output = Force;
    #[inline]
    fn sub(self, f: Force) -> Force {
        Force { linear: self.linear - f.linear, angular: self.angular - f.angular }
    }
}

impl std::ops::AddAssign for Force {
    #[inline]
    fn add_assign(&mut self, f: Force) {
        self.linear += f.linear;
        self.angular += f.angular;
    }
}

impl std::ops::SubAssign for Force {
    #[inline]
    fn sub_assign(&mut self, f: Force) {
        self.linear -= f.linear;
        self.angular -= f.angular;
    }
}

/// A rigid-body inertia: mass `m`, centre of mass `c` and rotational inertia `I_c` about the
/// centre of mass, all in the frame of the body.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Inertia {
    /// Mass `m` (kg).
    pub mass: f64,
    /// Centre of mass `c` (m), in the body frame.
    pub lever: Vector3<f64>,
    /// Rotational inertia about the centre of mass, `I_c` (kg·m²), in the body frame's axes.
    pub rotational: Matrix3<f64>,
}

impl Default for Inertia {
    fn default() -> Self {
        Self::zero()
    }
}

impl Inertia {
    /// The inertia of nothing.
    #[inline]
    pub fn zero() -> Self {
        Self { mass: 0.0, lever: Vector3::zeros(), rotational: Matrix3::zeros() }
    }

    /// Builds an inertia from mass, centre of mass and rotational inertia about it.
    pub fn new(mass: f64, lever: Vector3<f64>, rotational: Matrix3<f64>) -> Self {
        Self { mass, lever, rotational }
    }

    /// `I · m`: the momentum `(m (v − c × ω), I_c ω + c × f)` of the body moving with `m`.
    #[inline]
    pub fn mul_motion(&self, m: &Motion) -> Force {
        let linear = (m.linear - self.lever.cross(&m.angular)) * self.mass;
        Force { linear, angular: self.rotational * m.angular + self.lever.cross(&linear) }
    }

    /// The sum of two rigid bodies, about their joint centre of mass (parallel-axis theorem):
    /// `I_c = I₁ + I₂ + (m₁ m₂ / (m₁ + m₂)) (|d|² 𝟙 − d dᵀ)`, `d = c₁ − c₂`.
    pub fn add(&self, other: &Inertia) -> Inertia {
        let mass = self.mass + other.mass;
        if mass <= 0.0 {
            return Inertia { mass, lever: Vector3::zeros(), rotational: self.rotational + other.rotational };
        }
        let lever = (self.lever * self.mass + other.lever * other.mass) / mass;
        let d = self.lever - other.lever;
        let mu = self.mass * other.mass / mass;
        let parallel = (Matrix3::identity() * d.norm_squared() - d * d.transpose()) * mu;
        Inertia { mass, lever, rotational: self.rotational + other.rotational + parallel }
    }

    /// The 6×6 matrix `[[m 𝟙, −m [c]ₓ], [m [c]ₓ, I_c − m [c]ₓ[c]ₓ]]` (`[v; ω]` ordering).
    pub fn matrix(&self) -> Matrix6<f64> {
        let mut out = Matrix6::zeros();
        self.write_matrix(&mut out);
        out
    }

    /// Writes [`Inertia::matrix`] into `out`.
    #[inline]
    pub fn write_matrix(&self, out: &mut Matrix6<f64>) {
        let mc = skew(&self.lever) * self.mass;
        let m = self.mass;
        out.fixed_view_mut::<3, 3>(0, 0).copy_from(&(Matrix3::identity() * m));
        out.fixed_view_mut::<3, 3>(0, 3).copy_from(&(-mc));
        out.fixed_view_mut::<3, 3>(3, 0).copy_from(&mc);
        let ang = self.rotational - skew(&self.lever) * mc;
        out.fixed_view_mut::<3, 3>(3, 3).copy_from(&ang);
    }

    /// Rotational inertia about the frame origin, `I_c + m ([c]ₓ)ᵀ [c]ₓ`.
    #[inline]
    pub fn rotational_about_origin(&self) -> Matrix3<f64> {
        let (c, m) = (&self.lever, self.mass);
        let (xx, yy, zz) = (c.x * c.x, c.y * c.y, c.z * c.z);
        let mut r = self.rotational;
        add_symmetric(
            &mut r,
            [m * (yy + zz), m * (xx + zz), m * (xx + yy)],
            [m * c.x * c.y, m * c.x * c.z, m * c.y * c.z],
        );
        r
    }

    /// Kinetic energy `½ mᵀ I m` of the body moving with `m`.
    #[inline]
    pub fn kinetic_energy(&self, m: &Motion) -> f64 {
        0.5 * m.dot(&self.mul_motion(m))
    }
}

/// A rigid-body inertia parametrised at the frame origin: mass `m`, first moment
/// `h = m c` and rotational inertia about the origin `I_O = I_c + m([c]ₓ)ᵀ[c]ₓ`.
///
/// Unlike [`Inertia`] this form is additive (the inertia of a union of bodies is the sum of
/// the parts), which makes it the natural accumulator for world-frame composite inertias.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OriginInertia {
    /// Mass `m`.
    pub mass: f64,
    /// First moment of mass `h = m c`.
    pub first_moment: Vector3<f64>,
    /// Rotational inertia about the frame origin.
    pub rotational: Matrix3<f64>,
}

impl Default for OriginInertia {
    fn default() -> Self {
        Self::zero()
    }
}

impl OriginInertia {
    /// The inertia `y` (given in frame *b*) expressed at the origin of frame *a*, for
    /// `m = aMb`: `c_a = R c + p`, `I_O = R I_c Rᵀ + m(|c_a|² 𝟙 − c_a c_aᵀ)`.
    #[inline]
    pub fn from_placed_inertia(m: &Se3, y: &Inertia) -> Self {
        let c = m.act_point(&y.lever);
        let mut rot = rotate_symmetric(&m.rotation, &y.rotational);
        let (mx, my, mz) = (y.mass * c.x, y.mass * c.y, y.mass * c.z);
        let (xx, yy, zz) = (mx * c.x, my * c.y, mz * c.z);
        add_symmetric(&mut rot, [yy + zz, xx + zz, xx + yy], [mx * c.y, mx * c.z, my * c.z]);
        Self { mass: y.mass, first_moment: Vector3::new(mx, my, mz), rotational: rot }
    }

    /// Nothing.
    #[inline]
    pub fn zero() -> Self {
        Self { mass: 0.0, first_moment: Vector3::zeros(), rotational: Matrix3::zeros() }
    }

    /// From the centre-of-mass parametrisation, in the same frame.
    #[inline]
    pub fn from_inertia(y: &Inertia) -> Self {
        Self { mass: y.mass, first_moment: y.lever * y.mass, rotational: y.rotational_about_origin() }
    }

    /// Back to the centre-of-mass parametrisation (zero mass gives a zero lever).
    pub fn to_inertia(&self) -> Inertia {
        if self.mass <= 0.0 {
            return Inertia::new(self.mass, Vector3::zeros(), self.rotational);
        }
        let c = self.first_moment / self.mass;
        let shift = (Matrix3::identity() * c.norm_squared() - c * c.transpose()) * self.mass;
        Inertia::new(self.mass, c, self.rotational - shift)
    }

    /// The same inertia expressed in frame *a*, for `m = aMb` (this one given in *b*):
    /// with `h' = R h` and `p` the translation,
    /// `I_O' = R I_O Rᵀ + m(|p|² 𝟙 − p pᵀ) + 2(h'·p) 𝟙 − h' pᵀ − p h'ᵀ`, `h'' = h' + m p`.
    #[inline]
    pub fn transformed(&self, m: &Se3) -> Self {
        let p = &m.translation;
        let h = m.rotation * self.first_moment;
        let mut rot = rotate_symmetric(&m.rotation, &self.rotational);
        let mp = p * self.mass;
        // With g = m p + h', the correction is symmetric: g_r p_c + p_r h'_c.
        let g = mp + h;
        let diag = mp.dot(p) + 2.0 * h.dot(p);
        let off = |r: usize, c: usize| g[r] * p[c] + p[r] * h[c];
        add_symmetric(
            &mut rot,
            [diag - off(0, 0), diag - off(1, 1), diag - off(2, 2)],
            [off(0, 1), off(0, 2), off(1, 2)],
        );
        Self { mass: self.mass, first_moment: g, rotational: rot }
    }

    /// Adds another body's inertia (same frame).
    #[inline]
    pub fn add_assign(&mut self, o: &OriginInertia) {
        self.mass += o.mass;
        self.first_moment += o.first_moment;
        self.rotational += o.rotational;
    }

    /// Momentum about the origin of the body moving with `m = (v, ω)`:
    /// `(m v − h × ω, I_O ω + h × v)`.
    #[inline]
    pub fn mul_motion(&self, m: &Motion) -> Force {
        Force {
            linear: m.linear * self.mass - self.first_moment.cross(&m.angular),
            angular: self.rotational * m.angular + self.first_moment.cross(&m.linear),
        }
    }
}

/// Exponential map of a twist: the transform reached after moving for unit time with the
/// constant body twist `ν` (`exp6` in Pinocchio's terms).
pub fn exp6(nu: &Motion) -> Se3 {
    let w = nu.angular;
    let v = nu.linear;
    let theta2 = w.norm_squared();
    let theta = theta2.sqrt();
    let (a, b, c) = if theta < 1e-4 {
        // Taylor expansions of sinθ/θ, (1−cosθ)/θ², (θ−sinθ)/θ³.
        (1.0 - theta2 / 6.0, 0.5 - theta2 / 24.0, 1.0 / 6.0 - theta2 / 120.0)
    } else {
        let (s, co) = theta.sin_cos();
        (s / theta, (1.0 - co) / theta2, (theta - s) / (theta2 * theta))
    };
    let wx = skew(&w);
    let wx2 = wx * wx;
    let rotation = Matrix3::identity() + wx * a + wx2 * b;
    let vmat = Matrix3::identity() + wx * b + wx2 * c;
    Se3 { rotation, translation: vmat * v }
}

/// Logarithm of a rotation: the rotation vector `θ a` with `exp([θ a]ₓ) = R`.
///
/// `θ = atan2(|w|, (tr R − 1)/2)` with `w = vee(R − Rᵀ)/2 = sinθ a` keeps full precision
/// for small angles (where `acos` of the trace loses half the digits); near `π` the axis
/// comes from the symmetric part instead.
pub fn log3(r: &Matrix3<f64>) -> Vector3<f64> {
    let w = Vector3::new(r[(2, 1)] - r[(1, 2)], r[(0, 2)] - r[(2, 0)], r[(1, 0)] - r[(0, 1)]) * 0.5;
    let s = w.norm();
    let c = 0.5 * (r.trace() - 1.0);
    let theta = s.atan2(c);
    if s < 1e-9 && c > 0.0 {
        // θ/sinθ = 1 + θ²/6 + …
        return w * (1.0 + s * s / 6.0);
    }
    if theta < std::f64::consts::PI - 1e-4 {
        return w * (theta / s);
    }
    Rotation3::from_matrix_unchecked(*r).scaled_axis()
}

/// Logarithm of a transform: the body twist `ν` with `exp6(ν) = M` (angle below π).
pub fn log6(m: &Se3) -> Motion {
    let w = log3(&m.rotation);
    let theta2 = w.norm_squared();
    let theta = theta2.sqrt();
    let wx = skew(&w);
    // V⁻¹ = 𝟙 − ½[ω]ₓ + (1/θ²)(1 − (θ sinθ)/(2(1 − cosθ)))[ω]ₓ².
    let k = if theta < 1e-4 {
        1.0 / 12.0 + theta2 / 720.0
    } else {
        let (s, c) = theta.sin_cos();
        (1.0 - theta * s / (2.0 * (1.0 - c))) / theta2
    };
    let vinv = Matrix3::identity() - wx * 0.5 + wx * wx * k;
    Motion { linear: vinv * m.translation, angular: w }
}
