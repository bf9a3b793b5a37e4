//! `scenario.toml` and `plant.toml`: a scenario as the commented TOML of
//! `flexstage-scenario`, checked when read.

use flexstage_scenario::Scenario;

use crate::format::Format;

impl Format for Scenario {
    fn encode(&self) -> Result<Vec<u8>, String> {
        Ok(self.to_commented_toml().into_bytes())
    }

    fn decode(bytes: &[u8]) -> Result<Self, String> {
        let text = std::str::from_utf8(bytes).map_err(|e| format!("not UTF-8 text: {e}"))?;
        Scenario::from_toml_str(text, "the file").map_err(|e| e.to_string())
    }
}
