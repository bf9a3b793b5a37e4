//! Prints the built-in paper scenario as commented TOML (what `flexstage init` writes).
fn main() {
    print!(
        "{}",
        flexstage_scenario::Scenario::paper().to_commented_toml()
    );
}
