//! The page's routes: every path the server answers and the methods it
//! takes there, in one table. The dispatch (`App::route`) matches on the
//! [`Route`] found here, and a method a path does not take is answered 405
//! with the `Allow` header this table gives: the two cannot drift apart.

/// What a path is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Route {
    /// The page itself.
    Page,
    /// `/api/status`.
    Status,
    /// `/api/config`: the settings (GET), a change (POST).
    Config,
    /// `/api/fields`.
    Fields,
    /// `/api/log`.
    Log,
    /// `/api/audit`.
    Audit,
    /// `/api/session`.
    Session,
    /// `/api/setup`: the first administrator.
    Setup,
    /// `/api/login`.
    Login,
    /// `/api/logout`.
    Logout,
    /// `/api/password`: one's own password.
    Password,
    /// `/api/accounts`: the list (GET), a change (POST).
    Accounts,
    /// `/api/restart`.
    Restart,
    /// `/api/trigger/N`: one entry of the trigger table.
    Trigger,
    /// `/api/firmware`: an upload.
    Firmware,
}

/// The methods a path takes (HEAD wherever GET).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Methods {
    /// GET and HEAD.
    Get,
    /// POST.
    Post,
    /// GET, HEAD and POST.
    GetPost,
}

impl Methods {
    /// `true` if a request with `method` is taken.
    pub(crate) fn allow(self, method: &str) -> bool {
        let get = method == "GET" || method == "HEAD";
        let post = method == "POST";
        match self {
            Methods::Get => get,
            Methods::Post => post,
            Methods::GetPost => get || post,
        }
    }

    /// The `Allow` header of a 405 answer.
    pub(crate) fn header(self) -> &'static str {
        match self {
            Methods::Get => "GET, HEAD",
            Methods::Post => "POST",
            Methods::GetPost => "GET, HEAD, POST",
        }
    }
}

/// Every route: the path (a prefix where it ends in `/`), what it is, the
/// methods it takes.
const TABLE: &[(&str, Route, Methods)] = &[
    ("/", Route::Page, Methods::Get),
    ("/index.html", Route::Page, Methods::Get),
    ("/api/status", Route::Status, Methods::Get),
    ("/api/config", Route::Config, Methods::GetPost),
    ("/api/fields", Route::Fields, Methods::Get),
    ("/api/log", Route::Log, Methods::Get),
    ("/api/audit", Route::Audit, Methods::Get),
    ("/api/session", Route::Session, Methods::Get),
    ("/api/setup", Route::Setup, Methods::Post),
    ("/api/login", Route::Login, Methods::Post),
    ("/api/logout", Route::Logout, Methods::Post),
    ("/api/password", Route::Password, Methods::Post),
    ("/api/accounts", Route::Accounts, Methods::GetPost),
    ("/api/restart", Route::Restart, Methods::Post),
    ("/api/trigger/", Route::Trigger, Methods::Post),
    ("/api/firmware", Route::Firmware, Methods::Post),
];

/// The route of `path` and the methods it takes; `None`: not found.
pub(crate) fn lookup(path: &str) -> Option<(Route, Methods)> {
    TABLE.iter().find_map(|&(p, route, methods)| {
        let hit = if p.len() > 1 && p.ends_with('/') {
            path.starts_with(p)
        } else {
            path == p
        };
        hit.then_some((route, methods))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_path_has_one_route_and_its_methods() {
        assert_eq!(lookup("/"), Some((Route::Page, Methods::Get)));
        assert_eq!(
            lookup("/api/trigger/3"),
            Some((Route::Trigger, Methods::Post))
        );
        assert_eq!(lookup("/api/audit"), Some((Route::Audit, Methods::Get)));
        assert_eq!(lookup("/api/statuss"), None);
        assert_eq!(lookup("/api"), None);
        assert!(Methods::Get.allow("HEAD") && !Methods::Get.allow("POST"));
        assert!(Methods::GetPost.allow("POST") && !Methods::Post.allow("GET"));
        assert!(!Methods::GetPost.allow("PUT"));
        // A path is in the table once.
        for (i, (p, ..)) in TABLE.iter().enumerate() {
            assert!(TABLE[i + 1..].iter().all(|(q, ..)| q != p), "{p}");
        }
    }
}
