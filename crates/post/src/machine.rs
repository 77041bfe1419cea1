//! The machine a program is posted for: a five-axis machine definition
//! (`machines::FiveAxisConfig`) plus the words of its controller (`nc:`),
//! read from YAML. A cell config (launch_configs/*.yaml, with a `mill5:`
//! section) is read as its mill5 head with the default words.

use serde::{Deserialize, Serialize};
use std::path::Path;
use toolpath_kernel::error::{Error, Result};
use toolpath_machines::{FiveAxis, FiveAxisConfig, Mill5Config};

/// Controller words and number format, the `nc:` section of a machine file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct NcWords {
    /// Fanuc `O` number.
    pub program_number: u32,
    /// Tool number of the job's tool (pocket stages count on from it).
    pub tool_number: u32,
    pub spindle_rpm: f64,
    /// Spindle words; `M4` turns the APT `SPINDL` counter-clockwise.
    pub spindle_on: String,
    pub spindle_off: String,
    /// Coolant words; empty = none.
    pub coolant_on: String,
    pub coolant_off: String,
    /// Block numbers `N..` in this step; 0 = none (Heidenhain always numbers its blocks from 0).
    pub line_numbers: u32,
    /// Decimals of coordinates and angles.
    pub decimals: usize,
    /// LinuxCNC words that switch the kinematics to TCP and back (user
    /// M-codes of LinuxCNC's switchable-kinematics configurations).
    pub linuxcnc_tcp_on: String,
    pub linuxcnc_tcp_off: String,
}

impl Default for NcWords {
    fn default() -> Self {
        Self {
            program_number: 1000,
            tool_number: 1,
            spindle_rpm: 10000.0,
            spindle_on: "M3".into(),
            spindle_off: "M5".into(),
            coolant_on: "M8".into(),
            coolant_off: "M9".into(),
            line_numbers: 0,
            decimals: 4,
            linuxcnc_tcp_on: "M428".into(),
            linuxcnc_tcp_off: "M429".into(),
        }
    }
}

impl NcWords {
    pub fn validate(&self) -> Result<()> {
        if !self.spindle_rpm.is_finite() || self.spindle_rpm <= 0.0 {
            return Err(Error::invalid(
                "nc.spindle_rpm",
                format!("must be a positive finite number, got {}", self.spindle_rpm),
            ));
        }
        if !(1..=8).contains(&self.decimals) {
            return Err(Error::invalid(
                "nc.decimals",
                format!("must be 1..=8, got {}", self.decimals),
            ));
        }
        for (field, word) in [
            ("nc.spindle_on", &self.spindle_on),
            ("nc.spindle_off", &self.spindle_off),
            ("nc.coolant_on", &self.coolant_on),
            ("nc.coolant_off", &self.coolant_off),
            ("nc.linuxcnc_tcp_on", &self.linuxcnc_tcp_on),
            ("nc.linuxcnc_tcp_off", &self.linuxcnc_tcp_off),
        ] {
            if word
                .chars()
                .any(|c| !(c.is_ascii_alphanumeric() || c == '.' || c == ' '))
            {
                return Err(Error::invalid(
                    field,
                    format!("\"{word}\" is not an NC word (letters, digits, '.' and spaces only)"),
                ));
            }
        }
        if self.spindle_on.trim().is_empty() || self.spindle_off.trim().is_empty() {
            return Err(Error::invalid(
                "nc.spindle_on",
                "the spindle words must not be empty",
            ));
        }
        Ok(())
    }
}

/// A machine for the posts: kinematics and limits, and controller words.
#[derive(Clone, Debug, PartialEq)]
pub struct PostMachine {
    pub config: FiveAxisConfig,
    pub machine: FiveAxis,
    pub nc: NcWords,
}

impl PostMachine {
    /// The built-in mill5 (the default cell's head) with the default words.
    pub fn builtin_mill5() -> Self {
        Self::from_mill5(&Mill5Config::default())
    }

    /// A cell's mill5 head with the default words.
    pub fn from_mill5(cfg: &Mill5Config) -> Self {
        let config = FiveAxisConfig::from_mill5("mill5", cfg);
        let machine = config.build().expect("a validated mill5 config builds");
        Self {
            config,
            machine,
            nc: NcWords::default(),
        }
    }

    /// Parses a machine definition, or a cell config's `mill5:` section.
    pub fn parse(text: &str) -> Result<Self> {
        let value: serde_yaml_ng::Value = serde_yaml_ng::from_str(text)
            .map_err(|e| Error::invalid("", format!("not valid YAML: {e}")))?;
        let mut map = match value {
            serde_yaml_ng::Value::Mapping(m) => m,
            _ => {
                return Err(Error::invalid(
                    "",
                    "a machine definition is a YAML mapping (name, kinematics, axes, ...)",
                ))
            }
        };
        if let Some(mill5) = map.get("mill5") {
            let cfg: Mill5Config = deserialize(mill5.clone()).map_err(|e| e.within("mill5"))?;
            cfg.validate()?;
            return Ok(Self::from_mill5(&cfg));
        }
        let nc: NcWords = match map.remove("nc") {
            Some(v) => deserialize(v).map_err(|e| e.within("nc"))?,
            None => NcWords::default(),
        };
        nc.validate()?;
        let config: FiveAxisConfig = deserialize(serde_yaml_ng::Value::Mapping(map))?;
        let machine = config.build()?;
        Ok(Self {
            config,
            machine,
            nc,
        })
    }

    /// Reads a machine file; errors name the file and the field.
    pub fn read(path: &Path) -> Result<Self> {
        let text = toolpath_formats::read_text(path)?;
        Self::parse(&text).map_err(|e| e.in_file(path))
    }
}

fn deserialize<T: serde::de::DeserializeOwned>(value: serde_yaml_ng::Value) -> Result<T> {
    serde_path_to_error::deserialize(value).map_err(|e| {
        let path = e.path().to_string();
        let path = if path == "." { String::new() } else { path };
        Error::invalid(path, e.into_inner().to_string())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_cell_config_gives_its_mill5_head() {
        let m =
            PostMachine::parse("node:\n  workers: 2\nmill5:\n  pivot_length_mm: 320.0\n").unwrap();
        assert_eq!(m.machine.pivot_length, 320.0);
        assert_eq!(m.nc, NcWords::default());
        let e = PostMachine::parse("mill5:\n  pivot_lenght_mm: 3\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("mill5.pivot_lenght_mm"), "{e}");
    }

    #[test]
    fn words_are_checked() {
        let mut text = String::from("nc:\n  decimals: 12\n");
        text.push_str(&serde_yaml_ng::to_string(&PostMachine::builtin_mill5().config).unwrap());
        let e = PostMachine::parse(&text).unwrap_err().to_string();
        assert!(e.contains("nc.decimals: must be 1..=8, got 12"), "{e}");
        let e = PostMachine::parse("nc:\n  coolent_on: M8\n")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("nc.coolent_on: unknown field `coolent_on`"),
            "{e}"
        );
    }
}
