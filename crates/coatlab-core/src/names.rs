//! A value chosen by name from a fixed list (a view, an illuminant, a file axis):
//! the look-up ignores case and surrounding spaces, and a miss is refused with
//! every accepted name listed, so no message falls behind its list.

/// Text that names none of the accepted values.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("'{text}' is not {kind}: use {}", or_list(accepted))]
pub struct UnknownName {
    /// The text as given.
    pub text: String,
    /// What was asked for, with its article ("a view", "an axis").
    pub kind: &'static str,
    /// Every accepted name, in the order the help lists them.
    pub accepted: Vec<String>,
}

/// The value among `all` whose `name` is `text` (case and surrounding spaces
/// ignored), or the refusal listing every name.
pub fn by_name<T: Copy, N: AsRef<str>>(
    text: &str,
    kind: &'static str,
    all: &[T],
    name: impl Fn(T) -> N,
) -> Result<T, UnknownName> {
    all.iter()
        .copied()
        .find(|&value| name(value).as_ref().eq_ignore_ascii_case(text.trim()))
        .ok_or_else(|| UnknownName {
            text: text.to_owned(),
            kind,
            accepted: all.iter().map(|&v| name(v).as_ref().to_owned()).collect(),
        })
}

/// Names as a sentence lists them: "a", "a or b", "a, b or c".
pub fn or_list(names: &[impl AsRef<str>]) -> String {
    match names {
        [] => String::new(),
        [only] => only.as_ref().to_owned(),
        [init @ .., last] => {
            let init: Vec<&str> = init.iter().map(AsRef::as_ref).collect();
            format!("{} or {}", init.join(", "), last.as_ref())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_any_case_and_lists_every_name_on_a_miss() {
        let all = [1, 2, 3];
        let name = |v: i32| ["one", "two", "three"][v as usize - 1];
        assert_eq!(by_name(" TWO ", "a number", &all, name), Ok(2));
        let miss = by_name("four", "a number", &all, name).unwrap_err();
        assert_eq!(
            miss.to_string(),
            "'four' is not a number: use one, two or three"
        );
        assert_eq!(or_list(&["a"]), "a");
        assert_eq!(or_list(&["a", "b"]), "a or b");
        assert_eq!(or_list(&[] as &[&str]), "");
    }
}
