//! The URDF loader: what it accepts, what it rejects and how the error reads, and that no
//! input makes it panic.

mod common;

use centaur_dynamics::{BaseKind, JointKind, Model, UrdfError, UrdfOptions};
use proptest::prelude::*;

fn load(text: &str) -> Result<Model, UrdfError> {
    Model::from_urdf_str(text, "test.urdf", BaseKind::Floating)
}

fn load_with(text: &str, options: UrdfOptions) -> Result<Model, UrdfError> {
    Model::from_urdf_str_with(text, "test.urdf", BaseKind::Floating, options)
}

/// Centaur's behaviour before the loading policy.
fn strict() -> UrdfOptions {
    UrdfOptions { strict: true, ..UrdfOptions::default() }
}

/// Pinocchio's reading of non-physical inertias: as given.
fn accept() -> UrdfOptions {
    UrdfOptions { accept_nonphysical_inertia: true, ..UrdfOptions::default() }
}

const INERTIAL: &str = r#"<inertial><mass value="1"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial>"#;

fn robot(body: &str) -> String {
    format!(r#"<?xml version="1.0"?><robot name="r">{body}</robot>"#)
}

fn link(name: &str) -> String {
    format!(r#"<link name="{name}">{INERTIAL}</link>"#)
}

fn joint(name: &str, kind: &str, parent: &str, child: &str, extra: &str) -> String {
    format!(
        r#"<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/><axis xyz="0 1 0"/>{extra}</joint>"#
    )
}

const LIMIT: &str = r#"<limit lower="-1" upper="1" effort="10" velocity="5"/>"#;

/// Asserts the error's message names the file and contains every `needle`.
fn assert_message(err: &UrdfError, needles: &[&str]) {
    let msg = err.to_string();
    assert!(msg.contains("test.urdf"), "message does not name the file: {msg}");
    for n in needles {
        assert!(msg.contains(n), "message '{msg}' does not mention '{n}'");
    }
}

#[test]
fn a_valid_two_link_robot_loads_with_limits_and_dynamics() {
    let text = robot(&format!(
        "{}{}{}",
        link("base"),
        link("leg"),
        joint(
            "hip",
            "revolute",
            "base",
            "leg",
            &format!("{LIMIT}<dynamics damping=\"0.5\" friction=\"0.1\"/>")
        )
    ));
    let m = load(&text).unwrap();
    assert_eq!((m.nq, m.nv), (8, 7));
    assert_eq!(m.lower_position_limit[7], -1.0);
    assert_eq!(m.upper_position_limit[7], 1.0);
    assert_eq!(m.effort_limit[6], 10.0);
    assert_eq!(m.velocity_limit[6], 5.0);
    assert_eq!(m.damping[6], 0.5);
    assert_eq!(m.friction[6], 0.1);
    assert!((m.total_mass() - 2.0).abs() < 1e-15);
}

#[test]
fn fixed_links_are_merged_but_keep_their_frames() {
    let text = robot(&format!(
        "{}{}{}{}{}",
        link("base"),
        link("leg"),
        link("foot"),
        joint("hip", "revolute", "base", "leg", LIMIT),
        r#"<joint name="ankle" type="fixed"><parent link="leg"/><child link="foot"/><origin xyz="0 0 -0.3"/></joint>"#
    ));
    let m = load(&text).unwrap();
    assert_eq!(m.njoints(), 3, "universe, free-flyer, hip");
    let foot = m.frame_index("foot").unwrap();
    assert_eq!(m.frames[foot].parent_joint, 2);
    assert!((m.frames[foot].placement.translation.z + 0.3).abs() < 1e-15);
    // The hip body carries leg + foot: 2 kg with its centre of mass 0.15 m down.
    assert!((m.inertias[2].mass - 2.0).abs() < 1e-15);
    assert!((m.inertias[2].lever.z + 0.15).abs() < 1e-15);
}

#[test]
fn continuous_joints_and_limitless_revolute_knees_are_unlimited() {
    // The Minitaur's knees are `revolute` with <limit effort velocity> only.
    let m = Model::from_urdf_file(common::asset("minitaur/minitaur.urdf"), BaseKind::Floating).unwrap();
    let knee = m.joint_index("knee_front_rightR_link").unwrap();
    let iq = m.joints[knee].idx_q;
    assert!(m.lower_position_limit[iq].is_infinite() && m.upper_position_limit[iq].is_infinite());
    assert!(matches!(m.joints[knee].kind, JointKind::Revolute { .. }));
    assert_eq!(m.nv, 6 + 16);
    assert!((m.total_mass() - 6.0).abs() < 1e-12);
}

#[test]
fn massless_links_with_zero_inertia_are_accepted() {
    let text = robot(&format!(
        "{}{}{}",
        link("base"),
        r#"<link name="sensor"><inertial><mass value="0"/><inertia ixx="0" iyy="0" izz="0" ixy="0" ixz="0" iyz="0"/></inertial></link>"#,
        r#"<joint name="mount" type="fixed"><parent link="base"/><child link="sensor"/></joint>"#
    ));
    assert!(load(&text).is_ok());
}

#[test]
fn unresolvable_meshes_are_not_an_error() {
    let text = robot(&format!(
        r#"<link name="base">{INERTIAL}<visual><geometry><mesh filename="package://nowhere/base.stl"/></geometry></visual></link>"#
    ));
    let m = load(&text).unwrap();
    assert_eq!(m.geometries.len(), 1);
}

#[test]
fn unreadable_file_is_an_io_error_naming_it() {
    let err = Model::from_urdf_file("/nonexistent/robot.urdf", BaseKind::Fixed).unwrap_err();
    assert!(matches!(err, UrdfError::Io { .. }));
    assert!(err.to_string().contains("/nonexistent/robot.urdf"));
}

#[test]
fn non_urdf_xml_is_rejected() {
    let err =
        load(r#"<svg xmlns="http://www.w3.org/2000/svg"><rect width="10" height="10"/></svg>"#).unwrap_err();
    assert!(matches!(err, UrdfError::NotUrdf { .. }), "{err}");
    assert_message(&err, &["<svg>"]);
}

#[test]
fn malformed_xml_is_a_parse_error() {
    let err = load("<robot name=\"r\"><link name=\"a\"></robot>").unwrap_err();
    assert!(matches!(err, UrdfError::Parse { .. }), "{err}");
    let err = load("").unwrap_err();
    assert!(matches!(err, UrdfError::Parse { .. }), "{err}");
}

#[test]
fn robot_without_links_is_rejected() {
    let err = load(&robot("")).unwrap_err();
    assert!(matches!(err, UrdfError::NoLinks { .. }), "{err}");
}

#[test]
fn missing_parent_or_child_link_is_named() {
    let text = robot(&format!("{}{}", link("base"), joint("hip", "revolute", "ghost", "base", LIMIT)));
    let err = load(&text).unwrap_err();
    assert!(matches!(err, UrdfError::MissingLink { role: "parent", .. }), "{err}");
    assert_message(&err, &["hip", "ghost", "parent"]);
    let text = robot(&format!("{}{}", link("base"), joint("hip", "revolute", "base", "ghost", LIMIT)));
    let err = load(&text).unwrap_err();
    assert!(matches!(err, UrdfError::MissingLink { role: "child", .. }), "{err}");
}

#[test]
fn duplicate_names_are_rejected() {
    let err = load(&robot(&format!("{}{}", link("base"), link("base")))).unwrap_err();
    assert!(matches!(err, UrdfError::DuplicateLink { .. }), "{err}");
    assert_message(&err, &["base"]);
    let text = robot(&format!(
        "{}{}{}{}{}",
        link("a"),
        link("b"),
        link("c"),
        joint("j", "revolute", "a", "b", LIMIT),
        joint("j", "revolute", "a", "c", LIMIT)
    ));
    let err = load(&text).unwrap_err();
    assert!(matches!(err, UrdfError::DuplicateJoint { .. }), "{err}");
}

#[test]
fn cycles_and_several_roots_are_rejected() {
    let cycle = robot(&format!(
        "{}{}{}{}",
        link("a"),
        link("b"),
        joint("ab", "revolute", "a", "b", LIMIT),
        joint("ba", "revolute", "b", "a", LIMIT)
    ));
    let err = load(&cycle).unwrap_err();
    assert!(matches!(err, UrdfError::Cycle { .. }), "{err}");
    assert_message(&err, &["cycle"]);
    // A root plus a separate loop: still a cycle.
    let root_and_loop = robot(&format!(
        "{}{}{}{}{}",
        link("root"),
        link("a"),
        link("b"),
        joint("ab", "revolute", "a", "b", LIMIT),
        joint("ba", "revolute", "b", "a", LIMIT)
    ));
    assert!(matches!(load(&root_and_loop).unwrap_err(), UrdfError::Cycle { .. }));
    let two_roots = robot(&format!("{}{}", link("a"), link("b")));
    let err = load(&two_roots).unwrap_err();
    assert!(matches!(err, UrdfError::SeveralRoots { .. }), "{err}");
    assert_message(&err, &["a", "b"]);
    let two_parents = robot(&format!(
        "{}{}{}{}{}",
        link("a"),
        link("b"),
        link("c"),
        joint("ac", "revolute", "a", "c", LIMIT),
        joint("bc", "revolute", "b", "c", LIMIT)
    ));
    assert!(matches!(load(&two_parents).unwrap_err(), UrdfError::SeveralParents { .. }));
}

#[test]
fn non_physical_mass_and_inertia_are_rejected() {
    let neg = robot(
        r#"<link name="a"><inertial><mass value="-1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>"#,
    );
    for options in [UrdfOptions::default(), strict(), accept()] {
        let err = load_with(&neg, options).unwrap_err();
        assert!(matches!(err, UrdfError::NonPositiveMass { .. }), "{err}");
        assert_message(&err, &["link 'a'", "-1"]);
    }
    // 1 + 1 < 3: no rigid body has these principal moments, and this one carries all the mass.
    let triangle = robot(
        r#"<link name="a"><inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="3" ixy="0" ixz="0" iyz="0"/></inertial></link>"#,
    );
    let err = load(&triangle).unwrap_err();
    assert!(matches!(err, UrdfError::NonPhysicalBody { .. }), "{err}");
    assert_message(&err, &["root_joint", "[\"a\"]", "triangle", "accept_nonphysical_inertia"]);
    let err = load_with(&triangle, strict()).unwrap_err();
    assert!(matches!(err, UrdfError::NonPhysicalInertia { .. }), "{err}");
    assert_message(&err, &["triangle"]);
    // A negative principal moment (eigenvalues of [[1, 2], [2, 1]] are 3 and −1).
    let negative = robot(
        r#"<link name="a"><inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="2" ixz="0" iyz="0"/></inertial></link>"#,
    );
    let err = load(&negative).unwrap_err();
    assert!(matches!(err, UrdfError::NonPhysicalBody { .. }), "{err}");
    assert_message(&err, &["negative"]);
    assert!(matches!(load_with(&negative, strict()).unwrap_err(), UrdfError::NonPhysicalInertia { .. }));
}

#[test]
fn revolute_and_prismatic_joints_need_limits() {
    for kind in ["revolute", "prismatic"] {
        let text = robot(&format!("{}{}{}", link("a"), link("b"), joint("j", kind, "a", "b", "")));
        let err = load(&text).unwrap_err();
        assert!(matches!(err, UrdfError::MissingLimit { .. }), "{err}");
        assert_message(&err, &["joint 'j'", "<limit>"]);
    }
    let text = robot(&format!("{}{}{}", link("a"), link("b"), joint("j", "continuous", "a", "b", "")));
    assert!(load(&text).is_ok());
    let inverted = robot(&format!(
        "{}{}{}",
        link("a"),
        link("b"),
        joint("j", "revolute", "a", "b", r#"<limit lower="1" upper="-1" effort="1" velocity="1"/>"#)
    ));
    assert!(matches!(load(&inverted).unwrap_err(), UrdfError::InvertedLimits { .. }));
}

#[test]
fn nan_and_infinite_numbers_are_rejected() {
    let cases = [
        r#"<link name="a"><inertial><mass value="NaN"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>"#.to_string(),
        r#"<link name="a"><inertial><mass value="1"/><inertia ixx="inf" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>"#.to_string(),
        format!(
            "{}{}{}",
            link("a"),
            link("b"),
            r#"<joint name="j" type="continuous"><parent link="a"/><child link="b"/><origin xyz="0 nan 0"/></joint>"#
        ),
        format!(
            "{}{}{}",
            link("a"),
            link("b"),
            r#"<joint name="j" type="continuous"><parent link="a"/><child link="b"/><axis xyz="0 inf 0"/></joint>"#
        ),
    ];
    for body in cases {
        let err = load(&robot(&body)).unwrap_err();
        assert!(matches!(err, UrdfError::NonFinite { .. }), "{err}");
        assert_message(&err, &["finite"]);
    }
}

#[test]
fn zero_axes_and_unsupported_joints_are_rejected() {
    let zero = robot(&format!(
        "{}{}{}",
        link("a"),
        link("b"),
        r#"<joint name="j" type="continuous"><parent link="a"/><child link="b"/><axis xyz="0 0 0"/></joint>"#
    ));
    assert!(matches!(load(&zero).unwrap_err(), UrdfError::ZeroAxis { .. }));
    let planar = robot(&format!("{}{}{}", link("a"), link("b"), joint("j", "planar", "a", "b", "")));
    let err = load(&planar).unwrap_err();
    assert!(matches!(err, UrdfError::UnsupportedJoint { .. }), "{err}");
    assert_message(&err, &["planar"]);
}

#[test]
fn bad_geometry_sizes_are_rejected_in_strict_mode() {
    let text =
        robot(r#"<link name="a"><collision><geometry><sphere radius="-1"/></geometry></collision></link>"#);
    let err = load_with(&text, strict()).unwrap_err();
    assert!(matches!(err, UrdfError::BadGeometry { .. }), "{err}");
    // A NaN size is an error in every mode.
    let nan = robot(r#"<link name="a"><visual><geometry><sphere radius="NaN"/></geometry></visual></link>"#);
    assert!(matches!(load(&nan).unwrap_err(), UrdfError::NonFinite { .. }));
}

/// Text mutations a fuzzer would try: delete, duplicate or replace a span, swap in tokens
/// that matter to a URDF parser.
#[derive(Clone, Debug)]
enum Mutation {
    Delete(usize, usize),
    Duplicate(usize, usize),
    Insert(usize, &'static str),
    Truncate(usize),
}

const TOKENS: &[&str] = &[
    "<",
    ">",
    "/>",
    "\"",
    "NaN",
    "-inf",
    "1e400",
    "-1",
    "0",
    "</link>",
    "<joint name=\"x\" type=\"revolute\">",
    "<link name=\"base_chassis_link\"/>",
    "type=\"planar\"",
    "<limit/>",
    "<inertial>",
    "&amp;",
    "&#0;",
    "\u{0}",
    "é",
    "<robot>",
    "]]>",
    "<!--",
];

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        (any::<usize>(), 1usize..200).prop_map(|(a, n)| Mutation::Delete(a, n)),
        (any::<usize>(), 1usize..300).prop_map(|(a, n)| Mutation::Duplicate(a, n)),
        (any::<usize>(), prop::sample::select(TOKENS)).prop_map(|(a, t)| Mutation::Insert(a, t)),
        any::<usize>().prop_map(Mutation::Truncate),
    ]
}

fn apply(text: &str, muts: &[Mutation]) -> String {
    let mut s: Vec<char> = text.chars().collect();
    for m in muts {
        let n = s.len().max(1);
        match *m {
            Mutation::Delete(a, len) => {
                let a = a % n;
                let b = (a + len).min(s.len());
                s.drain(a.min(s.len())..b);
            }
            Mutation::Duplicate(a, len) => {
                let a = (a % n).min(s.len());
                let b = (a + len).min(s.len());
                let piece: Vec<char> = s[a..b].to_vec();
                s.splice(b..b, piece);
            }
            Mutation::Insert(a, t) => {
                let a = (a % n).min(s.len());
                s.splice(a..a, t.chars());
            }
            Mutation::Truncate(a) => s.truncate(a % n),
        }
    }
    s.into_iter().collect()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, ..ProptestConfig::default() })]

    /// No mutated URDF makes the loader panic: it returns a model or an error.
    #[test]
    fn mutated_urdf_text_never_panics(muts in prop::collection::vec(mutation(), 1..6)) {
        let original = std::fs::read_to_string(common::asset("minitaur/minitaur.urdf")).unwrap();
        let text = apply(&original, &muts);
        for options in [UrdfOptions::default(), strict(), accept()] {
            let _ = Model::from_urdf_str_with(&text, "mutated.urdf", BaseKind::Floating, options);
            let _ = Model::from_urdf_str_with(&text, "mutated.urdf", BaseKind::Fixed, options);
        }
    }
}
