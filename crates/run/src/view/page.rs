//! The frame every page of brachia shares: the document head (character set, viewport, a content
//! security policy that allows inline script and style and data images only, the title and the
//! style sheet of the light and dark themes, then the page's own rules) around the page's body.

use super::data::html_escape;

/// The style sheet every page embeds (light and dark themes).
pub const VIEW_STYLE: &str = include_str!("../../assets/view/view.css");

/// The header of a page whose script does not fill it: the title and the subtitle (both escaped
/// here) and the theme switch; no trailing newline.
pub fn header(title: &str, subtitle: &str) -> String {
    format!(
        "<header>\n  <div>\n    <h1 id=\"title\">{}</h1>\n    <p id=\"subtitle\">{}</p>\n  </div>\n  \
         <button id=\"theme\" type=\"button\" title=\"Switch between the light and dark theme\">dark / \
         light</button>\n</header>",
        html_escape(title),
        html_escape(subtitle)
    )
}

/// The page titled `title` (escaped here) whose style sheet is [`VIEW_STYLE`] followed by `style`
/// and whose body is `body` (the `<body>` element and what follows it, up to `</html>`).
pub fn page(title: &str, style: &str, body: &str) -> String {
    format!(
        "<!DOCTYPE html>\n\
         <html lang=\"en\">\n\
         <head>\n\
         <meta charset=\"utf-8\">\n\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n\
         <meta http-equiv=\"Content-Security-Policy\" content=\"default-src 'none'; \
         script-src 'unsafe-inline'; style-src 'unsafe-inline'; img-src data:\">\n\
         <title>{} - brachia</title>\n\
         <style>\n{VIEW_STYLE}\n{style}</style>\n\
         </head>\n\
         {body}</html>\n",
        html_escape(title)
    )
}
