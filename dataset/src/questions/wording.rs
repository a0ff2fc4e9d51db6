//! English for question texts: articles and plurals of class names.

/// `a chair`, `an armchair`.
pub fn with_article(name: &str) -> String {
    let article = if name.starts_with(['a', 'e', 'i', 'o', 'u']) { "an" } else { "a" };
    format!("{article} {name}")
}

/// `chair` → `chairs`, `shelf` → `shelves`, `box` → `boxes`, `dining chair` → `dining chairs`.
pub fn plural(name: &str) -> String {
    if let Some(stem) = name.strip_suffix("shelf") {
        return format!("{stem}shelves");
    }
    if name.ends_with('s') || name.ends_with('x') || name.ends_with("ch") || name.ends_with("sh") {
        return format!("{name}es");
    }
    if let Some(stem) = name.strip_suffix('y')
        && !stem.ends_with(['a', 'e', 'i', 'o', 'u'])
    {
        return format!("{stem}ies");
    }
    format!("{name}s")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plurals_follow_english_endings() {
        for (one, many) in [("chair", "chairs"), ("bookshelf", "bookshelves"), ("box", "boxes"), ("dining chair", "dining chairs"), ("bench", "benches")] {
            assert_eq!(plural(one), many);
        }
    }
}
