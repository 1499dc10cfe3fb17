//! The paper's parameters are bundled inside the core crate (so it packages on its own): the copy must
//! stay identical to the workspace's `params/paper.toml`, which the scenarios and the CLI read.

#[test]
fn bundled_paper_params_equal_the_workspace_file() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../params/paper.toml");
    let workspace = std::fs::read_to_string(path).expect("params/paper.toml of the workspace");
    assert_eq!(
        brachia::model::PAPER_TOML,
        workspace,
        "crates/core/params/paper.toml differs from params/paper.toml: copy one onto the other"
    );
    let robot = brachia::Robot::paper();
    assert_eq!(robot.n(), 4);
}
