//! `omnikin urdf` (issue 39): stdout or `--out` (an existing file kept without `--force`), a
//! well-formed document per preset, and a bad robot named. The joints' geometry is checked by
//! an independent URDF parser in crates/omnikin-py/tests/test_urdf.py.

#[path = "common/test_dir.rs"]
mod test_dir;

use assert_cmd::Command;

fn omnikin() -> Command {
    Command::cargo_bin("omnikin").unwrap()
}

#[test]
fn stdout_holds_one_document_with_a_joint_per_wheel() {
    for (robot, wheels, steer) in [("kiwi", 3, 0), ("swerve4", 4, 4), ("caster3", 3, 3)] {
        let out = omnikin().args(["urdf", robot]).output().unwrap();
        assert!(out.status.success());
        let xml = String::from_utf8(out.stdout).unwrap();
        assert!(xml.starts_with("<?xml version=\"1.0\"?>\n"), "{xml}");
        assert!(xml.trim_end().ends_with("</robot>"));
        assert_eq!(
            xml.matches("<joint name=\"wheel_").count(),
            wheels,
            "{robot}"
        );
        assert_eq!(
            xml.matches("<joint name=\"steer_").count(),
            steer,
            "{robot}"
        );
    }
}

#[test]
fn an_existing_out_file_is_replaced_only_with_force() {
    let dir = test_dir::TestDir::new("urdf", "force");
    let f = dir.path().join("robot.urdf");
    std::fs::write(&f, "keep me").unwrap();
    let out = omnikin()
        .args(["urdf", "ballbot", "--out"])
        .arg(&f)
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--force"));
    assert_eq!(std::fs::read_to_string(&f).unwrap(), "keep me");
    let out = omnikin()
        .args(["urdf", "ballbot", "--force", "--out"])
        .arg(&f)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        std::fs::read_to_string(&f)
            .unwrap()
            .contains("<robot name=\"ballbot\">")
    );
}

#[test]
fn an_unknown_robot_is_an_error() {
    let out = omnikin().args(["urdf", "tricycle"]).output().unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("tricycle"));
}
