//! The URDF loader's policy: what it accepts from published robots, with which warning,
//! and what strict mode (the earlier behaviour) refuses instead. One test per rule; the
//! robots are tiny hand-written URDFs shaped like the published files that motivated the
//! rule (named in each test).

use centaur_dynamics::{BaseKind, Model, UrdfError, UrdfOptions, UrdfWarning, aba, crba};

fn load(text: &str) -> Result<Model, UrdfError> {
    Model::from_urdf_str(text, "policy.urdf", BaseKind::Floating)
}

fn load_strict(text: &str) -> Result<Model, UrdfError> {
    let options = UrdfOptions { strict: true, ..UrdfOptions::default() };
    Model::from_urdf_str_with(text, "policy.urdf", BaseKind::Floating, options)
}

fn robot(body: &str) -> String {
    format!(r#"<?xml version="1.0"?><robot name="r">{body}</robot>"#)
}

/// A link with mass `m` (kg) and diagonal inertia.
fn link(name: &str, m: f64, i: [f64; 3]) -> String {
    format!(
        r#"<link name="{name}"><inertial><mass value="{m}"/><inertia ixx="{}" iyy="{}" izz="{}" ixy="0" ixz="0" iyz="0"/></inertial></link>"#,
        i[0], i[1], i[2]
    )
}

/// The trunk every test robot hangs off: 10 kg, a solid box.
fn trunk() -> String {
    link("trunk", 10.0, [0.1, 0.2, 0.25])
}

fn fixed(name: &str, parent: &str, child: &str) -> String {
    format!(r#"<joint name="{name}" type="fixed"><parent link="{parent}"/><child link="{child}"/></joint>"#)
}

fn revolute(name: &str, parent: &str, child: &str) -> String {
    format!(
        r#"<joint name="{name}" type="revolute"><parent link="{parent}"/><child link="{child}"/><origin xyz="0.2 0 0"/><axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="10" velocity="5"/></joint>"#
    )
}

fn has(model: &Model, pred: impl Fn(&UrdfWarning) -> bool) -> bool {
    model.load_warnings.iter().any(pred)
}

/// Go1, B1, ANYmal and HyQ: a dummy `base` link with principal moments `[−2.2e−22, 0, 3e−6]`
/// welded to the trunk. The body the dynamics uses (base + trunk) is physical.
#[test]
fn a_non_physical_dummy_link_merged_into_a_physical_body_is_accepted() {
    let text = robot(&format!(
        "{}{}{}",
        // ixx = 1.5e-6, iyy = 1.5e-6 − 2.2e-22, izz = 3e-6 would do; written as Go1 writes it.
        r#"<link name="base"><inertial><mass value="0.001"/><inertia ixx="0.0" iyy="0.0" izz="3e-6" ixy="0" ixz="0" iyz="0"/></inertial></link>"#,
        trunk(),
        fixed("floating_base", "base", "trunk")
    ));
    let model = load(&text).unwrap();
    assert!(has(&model, |w| matches!(w, UrdfWarning::NonPhysicalLinkMerged { link, joint, .. }
        if link == "base" && joint == "root_joint")));
    assert!(model.load_warnings.iter().any(|w| w.to_string().contains("merged across fixed joints")));
    let err = load_strict(&text).unwrap_err();
    assert!(matches!(err, UrdfError::NonPhysicalInertia { ref link, .. } if link == "base"), "{err}");
}

/// Bolt's feet, panda_link8, KUKA's link 0: `<mass value="0">` with a non-zero inertia.
#[test]
fn zero_mass_with_inertia_is_kept_as_given() {
    let text = robot(&format!(
        "{}{}{}",
        trunk(),
        link("foot", 0.0, [1e-6, 1e-6, 1e-6]),
        fixed("f", "trunk", "foot")
    ));
    let model = load(&text).unwrap();
    assert!(has(&model, |w| matches!(w, UrdfWarning::ZeroMassWithInertia { link } if link == "foot")));
    // Kept: the body's inertia about its centre of mass gains the foot's 1e-6.
    assert!((model.inertias[1].rotational[(0, 0)] - (0.1 + 1e-6)).abs() < 1e-15);
    assert!(matches!(load_strict(&text).unwrap_err(), UrdfError::NonPositiveMass { .. }));
}

/// A moving link of negligible mass (below 1e-3 of the robot's) whose inertia clearly
/// violates the triangle inequality: kept as given, with the reason.
#[test]
fn a_non_physical_body_of_negligible_mass_is_kept() {
    let text = robot(&format!(
        "{}{}{}",
        trunk(),
        link("antenna", 0.005, [1e-6, 1e-6, 3e-6]),
        revolute("antenna_joint", "trunk", "antenna")
    ));
    let model = load(&text).unwrap();
    let kept = model
        .load_warnings
        .iter()
        .find(|w| matches!(w, UrdfWarning::NonPhysicalBodyKept { joint, .. } if joint == "antenna_joint"))
        .expect("a NonPhysicalBodyKept warning");
    assert!(kept.to_string().contains("negligible"), "{kept}");
}

/// A negative principal moment makes the mass matrix indefinite (accelerations against the
/// torque): refused even on a body of negligible mass.
#[test]
fn a_negative_moment_is_refused_whatever_the_mass() {
    let text = robot(&format!(
        "{}{}{}",
        trunk(),
        link("flap", 0.005, [-1.0, 1.0, 1.0]),
        revolute("flap_joint", "trunk", "flap")
    ));
    let err = load(&text).unwrap_err();
    assert!(
        matches!(&err, UrdfError::NonPhysicalBody { joint, reason, .. } if joint == "flap_joint" && reason.contains("negative")),
        "{err}"
    );
}

/// The same violation on a body that carries mass is refused, and loads as given only on
/// request (example-robot-data's romeo_small, pybullet's mini_cheetah and xarm6).
#[test]
fn a_non_physical_body_with_mass_is_refused_unless_asked() {
    let text = robot(&format!(
        "{}{}{}",
        trunk(),
        link("thigh", 1.0, [0.001, 0.001, 0.003]),
        revolute("hip", "trunk", "thigh")
    ));
    let err = load(&text).unwrap_err();
    match &err {
        UrdfError::NonPhysicalBody { joint, links, mass, reason, .. } => {
            assert_eq!((joint.as_str(), links.as_slice(), *mass), ("hip", &["thigh".to_string()][..], 1.0));
            assert!(reason.contains("triangle"), "{reason}");
        }
        other => panic!("expected NonPhysicalBody, got {other}"),
    }
    let options = UrdfOptions { accept_nonphysical_inertia: true, ..UrdfOptions::default() };
    let model = Model::from_urdf_str_with(&text, "policy.urdf", BaseKind::Floating, options).unwrap();
    assert!(has(&model, |w| matches!(w, UrdfWarning::NonPhysicalBodyKept { joint, kept_because, .. }
        if joint == "hip" && kept_because.contains("accept_nonphysical_inertia"))));
}

/// iCub: bodies with mass and a zero rotational inertia written as ±1e−18. Rounding of the
/// robot's scale, not a violation: no error, no warning.
#[test]
fn a_rounding_level_violation_is_no_violation() {
    let text = robot(&format!(
        "{}{}{}",
        trunk(),
        r#"<link name="hip"><inertial><mass value="0.5"/><inertia ixx="-1e-18" iyy="0" izz="4e-18" ixy="0" ixz="0" iyz="0"/></inertial></link>"#,
        fixed("hip_mount", "trunk", "hip")
    ));
    let model = load(&text).unwrap();
    assert!(model.load_warnings.is_empty(), "{:?}", model.load_warnings);
    // A part in 10⁷ of a body's own moments is rounding too.
    let text = robot(&format!(
        "{}{}{}",
        trunk(),
        link("leg", 1.0, [0.01, 0.01, 0.0200000001]),
        revolute("hip", "trunk", "leg")
    ));
    assert!(load(&text).unwrap().load_warnings.is_empty());
}

/// Romeo's hands: moving links with no mass and no inertia. Accepted as zero-inertia
/// bodies (as Pinocchio does); the mass matrix is singular there and the warning says so.
#[test]
fn a_massless_moving_leaf_is_reported_as_a_singular_mass_matrix() {
    let text = robot(&format!(
        "{}{}{}{}{}",
        trunk(),
        link("arm", 1.0, [0.01, 0.01, 0.001]),
        revolute("shoulder", "trunk", "arm"),
        r#"<link name="finger"/>"#,
        revolute("finger_joint", "arm", "finger")
    ));
    for model in [load(&text).unwrap(), load_strict(&text).unwrap()] {
        let singular: Vec<&str> = model
            .load_warnings
            .iter()
            .filter_map(|w| match w {
                UrdfWarning::SingularMassMatrix { joint, .. } => Some(joint.as_str()),
                _ => None,
            })
            .collect();
        // Only the finger: the factorisation steps around its zero pivot, so its ancestors'
        // pivots are not spoilt.
        assert_eq!(singular, ["finger_joint"]);
        let mut data = centaur_dynamics::Data::new(&model);
        let q = model.neutral_configuration();
        let m = crba(&model, &mut data, q.as_slice());
        assert_eq!(m[(model.nv - 1, model.nv - 1)], 0.0);
        let ddq = aba(&model, &mut data, q.as_slice(), &vec![0.0; model.nv], &vec![0.0; model.nv]);
        assert!(!ddq.iter().all(|x| x.is_finite()), "ABA is undefined here, as in Pinocchio");
    }
}

/// iCub: `<texture/>` without a filename in a visual's material, which urdf-rs refuses
/// ("custom: missing field `filename`"). The dynamics never reads materials: the file is
/// read again without them.
#[test]
fn a_file_urdf_rs_cannot_read_is_read_again_without_what_the_dynamics_ignores() {
    let text = robot(&format!(
        r#"<link name="trunk"><inertial><mass value="10"/><inertia ixx="0.1" iyy="0.2" izz="0.25" ixy="0" ixz="0" iyz="0"/></inertial>
          <visual><geometry><box size="0.3 0.2 0.1"/></geometry><material name="black"><texture/><color rgba="0 0 0 1"/></material></visual>
          <collision><geometry><box size="0.3 0.2 0.1"/></geometry></collision></link>
        {}{}"#,
        link("leg", 1.0, [0.01, 0.01, 0.001]),
        revolute("hip", "trunk", "leg")
    ));
    let model = load(&text).unwrap();
    assert!(has(&model, |w| matches!(w, UrdfWarning::Reread { message } if message.contains("filename"))));
    // The shapes survive the second reading, the colour too.
    assert_eq!(model.geometries.len(), 2);
    assert_eq!(model.geometries.iter().find_map(|g| g.rgba), Some([0.0, 0.0, 0.0, 1.0]));
    assert!((model.total_mass() - 11.0).abs() < 1e-12);
    let err = load_strict(&text).unwrap_err();
    assert!(matches!(err, UrdfError::Parse { .. }), "{err}");
}

/// The second reading of a file whose `<robot>` declares namespace prefixes (xacro, Gazebo)
/// used inside the elements it keeps: the prefixed attributes and elements are left out of
/// the reduced document (an unbound prefix made the XML writer panic).
#[test]
fn namespaced_attributes_in_kept_elements_do_not_break_the_second_reading() {
    let text = r#"<robot name="r" xmlns:foo="urn:x" xmlns:xacro="http://www.ros.org/wiki/xacro">
      <link name="a"><inertial foo:k="1"><origin xyz="0 0 0" foo:tag="o"/><mass value="1"/>
        <inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/><foo:extra v="2"/></inertial>
        <visual><origin xyz="0 0 0" xacro:note="n"/><geometry><box size="1 1 1"/></geometry>
          <material name="m"><texture/></material></visual></link>
      <link name="b"><inertial><mass value="0.5"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>
      <joint name="j" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 1" foo:a="1"/>
        <limit lower="-1" upper="1" effort="1" velocity="1" xacro:x="y"/></joint>
    </robot>"#;
    let model = load(text).unwrap();
    assert!(has(&model, |w| matches!(w, UrdfWarning::Reread { .. })));
    assert!((model.total_mass() - 1.5).abs() < 1e-12);
    assert_eq!(model.geometries.len(), 1);
}

/// A geometry urdf-rs cannot read (pybullet's racecar puts a `<material>` inside
/// `<geometry>`; a mesh without a file): on the second reading that shape is dropped,
/// with a warning naming it, and the rest of the robot loads.
#[test]
fn unreadable_shapes_are_dropped_on_the_second_reading() {
    let text = robot(
        r#"<link name="trunk"><inertial><mass value="10"/><inertia ixx="0.1" iyy="0.2" izz="0.25" ixy="0" ixz="0" iyz="0"/></inertial>
          <visual><geometry><mesh filename="body.stl"/><material name="grey"/></geometry></visual>
          <visual><geometry><mesh/></geometry></visual>
          <collision><geometry><sphere radius="0.1"/></geometry></collision></link>"#,
    );
    let model = load(&text).unwrap();
    assert!(has(&model, |w| matches!(w, UrdfWarning::Reread { .. })));
    assert!(has(&model, |w| matches!(w, UrdfWarning::Dropped { element, reason }
        if element == "link 'trunk' <visual> 1" && reason.contains("filename"))));
    // The first visual (its mesh and its misplaced material) and the collision remain.
    assert_eq!(model.geometries.len(), 2);
    assert!(load_strict(&text).is_err());
}

/// pybullet's laikago_toes: visual spheres of radius 0 on the toes.
#[test]
fn degenerate_shapes_are_dropped() {
    let text = robot(
        r#"<link name="trunk"><inertial><mass value="10"/><inertia ixx="0.1" iyy="0.2" izz="0.25" ixy="0" ixz="0" iyz="0"/></inertial>
          <visual><geometry><sphere radius="0"/></geometry></visual>
          <collision><geometry><box size="0.3 0.2 0.1"/></geometry></collision></link>"#,
    );
    let model = load(&text).unwrap();
    assert!(has(
        &model,
        |w| matches!(w, UrdfWarning::Dropped { element, .. } if element == "link 'trunk' <visual> 0")
    ));
    assert_eq!(model.geometries.len(), 1);
    assert!(matches!(load_strict(&text).unwrap_err(), UrdfError::BadGeometry { .. }));
}

/// `<gazebo>`, `<transmission>`, `ros2_control`, pybullet's `<contact>`, `<safety_controller>`
/// and `<mimic>` are not read; each kind is reported once with its count, every mimic by name.
#[test]
fn ignored_elements_are_counted_and_mimics_named() {
    let text = robot(&format!(
        r#"{}{}<gazebo reference="trunk"/><gazebo/><transmission name="t"/><ros2_control name="x"/>
          <joint name="hip" type="revolute"><parent link="trunk"/><child link="leg"/><axis xyz="0 1 0"/>
            <limit lower="-1" upper="1" effort="10" velocity="5"/><safety_controller k_velocity="1"/></joint>
          {}<joint name="knee" type="revolute"><parent link="leg"/><child link="shin"/><axis xyz="0 1 0"/>
            <limit lower="-1" upper="1" effort="10" velocity="5"/><mimic joint="hip" multiplier="2"/></joint>"#,
        trunk(),
        link("leg", 1.0, [0.01, 0.01, 0.001]),
        link("shin", 0.5, [0.005, 0.005, 0.001]),
    ));
    let model = load(&text).unwrap();
    let ignored: Vec<(String, usize)> = model
        .load_warnings
        .iter()
        .filter_map(|w| match w {
            UrdfWarning::Ignored { tag, count } => Some((tag.clone(), *count)),
            _ => None,
        })
        .collect();
    assert_eq!(
        ignored,
        [
            ("joint/safety_controller".to_string(), 1),
            ("robot/gazebo".to_string(), 2),
            ("robot/ros2_control".to_string(), 1),
            ("robot/transmission".to_string(), 1)
        ]
    );
    assert!(has(
        &model,
        |w| matches!(w, UrdfWarning::MimicIgnored { joint, leader } if joint == "knee" && leader == "hip")
    ));
    // The mimicking joint is an independent degree of freedom.
    assert_eq!(model.nv, 6 + 2);
}

/// Structural refusals do not depend on the mode.
#[test]
fn structural_errors_stay_errors_in_every_mode() {
    let missing = robot(&format!("{}{}", trunk(), revolute("hip", "trunk", "nowhere")));
    let accept = UrdfOptions { accept_nonphysical_inertia: true, ..UrdfOptions::default() };
    for options in [UrdfOptions::default(), accept] {
        let err =
            Model::from_urdf_str_with(&missing, "policy.urdf", BaseKind::Floating, options).unwrap_err();
        assert!(matches!(err, UrdfError::MissingLink { .. }), "{err}");
    }
    let no_limit = robot(&format!(
        r#"{}{}<joint name="hip" type="revolute"><parent link="trunk"/><child link="leg"/><axis xyz="0 1 0"/></joint>"#,
        trunk(),
        link("leg", 1.0, [0.01, 0.01, 0.001])
    ));
    assert!(matches!(load(&no_limit).unwrap_err(), UrdfError::MissingLimit { .. }));
}

/// The models every other test and the controller use load exactly as before the policy:
/// the default and strict readings give the same model.
#[test]
fn the_default_reading_of_physical_files_equals_the_strict_one() {
    let root = concat!(env!("CARGO_MANIFEST_DIR"), "/../assets");
    for (file, base) in [
        ("minitaur/minitaur.urdf", BaseKind::Floating),
        ("solo12/solo12.urdf", BaseKind::Floating),
        ("talos/talos_reduced.urdf", BaseKind::Floating),
        ("ur5/ur5_robot.urdf", BaseKind::Fixed),
        ("mujoco/walker2d.urdf", BaseKind::Fixed),
    ] {
        let path = format!("{root}/{file}");
        let a = Model::from_urdf_file(&path, base).unwrap();
        let options = UrdfOptions { strict: true, ..UrdfOptions::default() };
        let b = Model::from_urdf_file_with(&path, base, options).unwrap();
        assert_eq!(format!("{:?}", a.inertias), format!("{:?}", b.inertias), "{file}");
        assert_eq!(format!("{:?}", a.joints), format!("{:?}", b.joints), "{file}");
        assert_eq!(a.geometries.len(), b.geometries.len(), "{file}");
    }
}
