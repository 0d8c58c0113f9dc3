//! Flags whose value is one of a list of names ([`Named`]): clap takes the
//! names from the list the owning crate keeps, so the command line mirrors
//! no enum of its own.

use crate::param::Named;
use clap::builder::{PossibleValue, TypedValueParser};
use std::marker::PhantomData;

/// A clap value parser for `T` by its names: `value_parser = named::<T>()`.
pub(crate) fn named<T: Named + Send + Sync>() -> NamedParser<T> {
    NamedParser(PhantomData)
}

/// Parses a flag's value into the `T` of that name; the help and the error
/// list `T::NAMES`.
#[derive(Clone, Copy)]
pub(crate) struct NamedParser<T>(PhantomData<T>);

impl<T: Named + Send + Sync> TypedValueParser for NamedParser<T> {
    type Value = T;

    fn parse_ref(
        &self,
        cmd: &clap::Command,
        arg: Option<&clap::Arg>,
        value: &std::ffi::OsStr,
    ) -> Result<T, clap::Error> {
        let text = value.to_string_lossy();
        T::by_name(&text).ok_or_else(|| {
            let mut e = clap::Error::new(clap::error::ErrorKind::InvalidValue).with_cmd(cmd);
            if let Some(arg) = arg {
                e.insert(
                    clap::error::ContextKind::InvalidArg,
                    clap::error::ContextValue::String(arg.to_string()),
                );
            }
            e.insert(
                clap::error::ContextKind::InvalidValue,
                clap::error::ContextValue::String(text.into_owned()),
            );
            e.insert(
                clap::error::ContextKind::ValidValue,
                clap::error::ContextValue::Strings(
                    T::NAMES.iter().map(|n| n.to_string()).collect(),
                ),
            );
            e
        })
    }

    fn possible_values(&self) -> Option<Box<dyn Iterator<Item = PossibleValue> + '_>> {
        Some(Box::new(T::NAMES.iter().map(PossibleValue::new)))
    }
}
