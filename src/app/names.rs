//! Names chosen on the command line, in Python and in manifests, read back
//! into values ([`Named`]), and the names reports give to what happened.

use super::error::AppError;
use crate::param::Named;

/// The value of `T` called `value`, else a usage error naming `flag` and
/// the choices: `--interp must be one of linear, nearest, got 'cubic'`.
///
/// # Errors
/// [`AppError::Usage`] for a name that is not one of `T::NAMES`.
pub fn parse<T: Named>(flag: &str, value: &str) -> Result<T, AppError> {
    T::by_name(value).ok_or_else(|| {
        AppError::Usage(format!(
            "{flag} must be one of {}, got '{value}'",
            T::NAMES.join(", ")
        ))
    })
}

/// The report's name of a solver's stop reason (`max_iterations`, ...).
pub fn stop_name(r: crate::param::StopReason) -> String {
    serde_json::to_value(r)
        .ok()
        .and_then(|v| v.as_str().map(str::to_string))
        .unwrap_or_else(|| format!("{r:?}"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::app::run::frame::MeshFrame;

    #[test]
    fn a_name_not_in_the_list_is_a_usage_error_listing_the_choices() {
        assert_eq!(
            parse::<MeshFrame>("--mesh-frame", "lps").unwrap(),
            MeshFrame::Lps
        );
        let e = parse::<MeshFrame>("--mesh-frame", "LPS").unwrap_err();
        assert_eq!(
            e.to_string(),
            "--mesh-frame must be one of auto, ras, lps, got 'LPS'"
        );
    }
}
