//! Open-loop sanity check without a simulator: the single-rigid-body model integrated under
//! the MPC's first forces (re-solved every step) recovers from a perturbation and tracks a
//! commanded velocity.

use centaur_dynamics::nalgebra::{Matrix3, Rotation3, Vector3};
use centaur_mpc::NX;
use centaur_mpc::{ConvexMpc, MpcConfig};

const M: f64 = 2.5;

struct Body {
    p: Vector3<f64>,
    v: Vector3<f64>,
    r: Rotation3<f64>,
    w: Vector3<f64>,
}

/// Integrates the exact rigid-body equations (not the MPC's linearisation) for `dt`.
fn step(b: &mut Body, inertia: &Matrix3<f64>, feet: &[Vector3<f64>], f: &[Vector3<f64>], dt: f64) {
    let mut force = Vector3::new(0.0, 0.0, -9.81 * M);
    let mut torque = Vector3::zeros();
    for (p, fi) in feet.iter().zip(f) {
        force += fi;
        torque += (p - b.p).cross(fi);
    }
    let iw = b.r.matrix() * inertia * b.r.matrix().transpose();
    let wdot = iw.try_inverse().unwrap() * (torque - b.w.cross(&(iw * b.w)));
    b.v += force / M * dt;
    b.p += b.v * dt;
    b.w += wdot * dt;
    b.r = Rotation3::new(b.w * dt) * b.r;
}

fn run(v_cmd: f64, mut b: Body, seconds: f64) -> Body {
    let inertia = Matrix3::from_diagonal(&Vector3::new(0.03, 0.05, 0.07));
    let mut mpc = ConvexMpc::new(&MpcConfig::stand(), 4, M, inertia).unwrap();
    let offsets = [
        Vector3::new(0.19, 0.15, 0.0),
        Vector3::new(0.19, -0.15, 0.0),
        Vector3::new(-0.19, 0.15, 0.0),
        Vector3::new(-0.19, -0.15, 0.0),
    ];
    let dt = 0.002;
    let steps = (seconds / dt) as usize;
    let mut feet = [Vector3::zeros(); 4];
    let mut f = [Vector3::zeros(); 4];
    for k in 0..steps {
        // Feet stay under the hips (as if stepping perfectly), on the ground.
        for i in 0..4 {
            feet[i] = Vector3::new(b.p.x + offsets[i].x, b.p.y + offsets[i].y, 0.0);
        }
        if k % 10 == 0 {
            let (roll, pitch, yaw) = b.r.euler_angles();
            let mut x0 = [0.0; NX];
            x0[..3].copy_from_slice(&[roll, pitch, yaw]);
            x0[3..6].copy_from_slice(b.p.as_slice());
            x0[6..9].copy_from_slice(b.w.as_slice());
            x0[9..12].copy_from_slice(b.v.as_slice());
            x0[12] = -9.81;
            mpc.input.x0 = x0;
            let h = mpc.config().horizon;
            let dtm = mpc.config().dt;
            for j in 0..h {
                let t = (j + 1) as f64 * dtm;
                let mut r = [0.0; NX];
                r[3] = b.p.x + v_cmd * t;
                r[4] = b.p.y;
                r[5] = 0.2;
                r[9] = v_cmd;
                r[12] = -9.81;
                mpc.input.x_ref[j] = r;
                for i in 0..4 {
                    mpc.input.contact[j][i] = true;
                    mpc.input.foot[j][i] = feet[i] + Vector3::new(v_cmd * t, 0.0, 0.0);
                }
            }
            assert!(mpc.solve().is_ok());
            for i in 0..4 {
                f[i] = mpc.force(0, i);
            }
        }
        step(&mut b, &inertia, &feet, &f, dt);
    }
    b
}

#[test]
fn recovers_from_a_tilt_and_height_error() {
    let b = Body {
        p: Vector3::new(0.0, 0.0, 0.17),
        v: Vector3::new(0.0, 0.2, 0.0),
        r: Rotation3::from_euler_angles(0.15, -0.1, 0.0),
        w: Vector3::new(0.5, 0.0, 0.0),
    };
    let b = run(0.0, b, 1.5);
    let (roll, pitch, _) = b.r.euler_angles();
    assert!((b.p.z - 0.2).abs() < 0.01, "height {}", b.p.z);
    assert!(roll.abs() < 0.02 && pitch.abs() < 0.02, "roll {roll}, pitch {pitch}");
    assert!(b.v.norm() < 0.05, "velocity {:?}", b.v);
}

#[test]
fn tracks_a_forward_velocity() {
    let b = Body {
        p: Vector3::new(0.0, 0.0, 0.2),
        v: Vector3::zeros(),
        r: Rotation3::identity(),
        w: Vector3::zeros(),
    };
    let b = run(0.3, b, 2.0);
    assert!((b.v.x - 0.3).abs() < 0.05, "vx {}", b.v.x);
    assert!((b.p.z - 0.2).abs() < 0.01, "height {}", b.p.z);
}
