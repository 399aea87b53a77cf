//! Named accounts and their roles (IEC 62443-4-2 CR 1.1 RE1: every human
//! user identified; CR 2.1 RE2: permissions by role).
//!
//! Up to [`ACCOUNTS`] accounts, each with a name, a [`Role`] and a salted
//! password hash. The roles are ordered: each may do what the ones below
//! it may.
//!
//! | role | may |
//! |---|---|
//! | `viewer` | read the status, configuration, log and audit log (also when reading without login is off) |
//! | `operator` | what a viewer may, and the operating actions of the page (reserved: none is served yet) |
//! | `admin` | everything: configuration, trigger table, accounts, access settings, restart |
//!
//! There is always an administrator once there is any account: the first
//! account is an administrator, created with the setup code
//! ([`super::setup`]), and the last administrator can be neither removed
//! nor made something else. Until an administrator exists the access
//! settings cannot be changed over Modbus (see `registers::view`).

use crate::access::password::{PasswordHash, STORED_LEN};

/// Accounts at most: 8 with the web page (feature `web`); none without it
/// (the core firmware has no page to log in to, and keeps no room for
/// them: its stored image has no account, and the access settings change
/// over Modbus only after a recovery start).
pub const ACCOUNTS: usize = if cfg!(feature = "web") { 8 } else { 0 };
/// Bytes of a name at most.
pub const NAME_MAX: usize = 16;
/// Addresses remembered per account as its own: those it last logged in
/// from (the rate limit of guesses treats them apart, see
/// `access::limit`), kept with the accounts.
pub const TRUSTED: usize = 4;
/// An account's own addresses, the most recent first (see [`TRUSTED`]).
pub type Trusted = [Option<core::net::Ipv4Addr>; TRUSTED];

/// What an account may do.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Role {
    /// Reads.
    Viewer = 1,
    /// Reads and operates.
    Operator = 2,
    /// Everything.
    Admin = 3,
}

impl Role {
    /// The role's word (`viewer`, `operator`, `admin`).
    pub fn as_str(self) -> &'static str {
        match self {
            Role::Viewer => "viewer",
            Role::Operator => "operator",
            Role::Admin => "admin",
        }
    }

    /// Reads a role's word.
    pub fn parse(s: &str) -> Option<Role> {
        [Role::Viewer, Role::Operator, Role::Admin]
            .into_iter()
            .find(|r| r.as_str() == s)
    }

    /// The stored byte.
    pub(crate) fn from_u8(b: u8) -> Option<Role> {
        match b {
            1 => Some(Role::Viewer),
            2 => Some(Role::Operator),
            3 => Some(Role::Admin),
            _ => None,
        }
    }
}

/// An account's name: 1 to 16 characters, lower-case letters,
/// digits, `.`, `_` and `-`, beginning with a letter (nothing a log, a CSV
/// file or a page must escape).
#[derive(Clone, Copy, PartialEq, Eq)]
pub struct UserName {
    bytes: [u8; NAME_MAX],
    len: u8,
}

impl core::fmt::Debug for UserName {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.as_str())
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for UserName {
    fn format(&self, f: defmt::Formatter) {
        defmt::write!(f, "{=str}", self.as_str())
    }
}

impl UserName {
    /// Reads a name; `None` if it breaks the rules.
    pub fn new(s: &[u8]) -> Option<UserName> {
        let ok = matches!(s.first(), Some(b'a'..=b'z'))
            && s.len() <= NAME_MAX
            && s.iter()
                .all(|&b| matches!(b, b'a'..=b'z' | b'0'..=b'9' | b'.' | b'_' | b'-'));
        if !ok {
            return None;
        }
        let mut bytes = [0; NAME_MAX];
        bytes.get_mut(..s.len())?.copy_from_slice(s);
        Some(UserName {
            bytes,
            len: s.len() as u8,
        })
    }

    /// The name.
    pub fn as_bytes(&self) -> &[u8] {
        self.bytes.get(..usize::from(self.len)).unwrap_or(&[])
    }

    /// The name as text.
    pub fn as_str(&self) -> &str {
        core::str::from_utf8(self.as_bytes()).unwrap_or("")
    }
}

/// An account.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Account {
    /// Its name.
    pub name: UserName,
    /// What it may do.
    pub role: Role,
    /// Its password's salted hash.
    pub hash: PasswordHash,
}

/// Bytes of one stored account: name length, name (padded), role, hash.
pub(crate) const ACCOUNT_STORED: usize = 1 + NAME_MAX + 1 + STORED_LEN;

impl Account {
    /// The stored form.
    pub(crate) fn to_bytes(self) -> [u8; ACCOUNT_STORED] {
        let mut out = [0u8; ACCOUNT_STORED];
        let (len, rest) = out.split_at_mut(1);
        let (name, rest) = rest.split_at_mut(NAME_MAX);
        let (role, hash) = rest.split_at_mut(1);
        len.fill(self.name.len);
        name.copy_from_slice(&self.name.bytes);
        role.fill(self.role as u8);
        hash.copy_from_slice(&self.hash.to_bytes());
        out
    }

    /// Reads the stored form; `None` if any part is invalid.
    pub(crate) fn from_bytes(b: &[u8]) -> Option<Account> {
        let len = usize::from(*b.first()?);
        let name = UserName::new(b.get(1..1 + len.min(NAME_MAX))?)?;
        let role = Role::from_u8(*b.get(1 + NAME_MAX)?)?;
        let hash = b.get(2 + NAME_MAX..ACCOUNT_STORED)?.try_into().ok()?;
        Some(Account {
            name,
            role,
            hash: PasswordHash::from_bytes(hash)?,
        })
    }
}

/// Why an account change is refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum AccountError {
    /// [`ACCOUNTS`] exist already.
    Full,
    /// An account of that name exists.
    Exists,
    /// No account of that name.
    Unknown,
    /// It would leave no administrator.
    LastAdmin,
}

impl AccountError {
    /// A text for the page.
    pub fn as_str(self) -> &'static str {
        match self {
            AccountError::Full => "8 accounts exist already",
            AccountError::Exists => "an account of that name exists",
            AccountError::Unknown => "no account of that name",
            AccountError::LastAdmin => "the last administrator stays an administrator",
        }
    }
}

/// The accounts, and the addresses each last logged in from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct Accounts {
    list: [Option<Account>; ACCOUNTS],
    /// Per account (by index): its own addresses ([`TRUSTED`]).
    trusted: [Trusted; ACCOUNTS],
}

impl Accounts {
    /// No account.
    pub const NONE: Accounts = Accounts {
        list: [None; ACCOUNTS],
        trusted: [[None; TRUSTED]; ACCOUNTS],
    };

    /// The own addresses of account `index` (the most recent first; none
    /// for an index without an account).
    pub fn trusted(&self, index: usize) -> Trusted {
        match self.at(index) {
            Some(_) => self.trusted.get(index).copied().unwrap_or([None; TRUSTED]),
            None => [None; TRUSTED],
        }
    }

    /// Which of account `index`'s own addresses `ip` is, if it is one.
    pub fn own_address(&self, index: usize, ip: Option<core::net::Ipv4Addr>) -> Option<usize> {
        let ip = ip?;
        self.trusted(index).iter().position(|t| *t == Some(ip))
    }

    /// Account `index` logged in from `ip`: one of its own addresses from
    /// now on (the oldest of [`TRUSTED`] goes). `true` if that changed the
    /// accounts (they are then saved).
    pub fn trust(&mut self, index: usize, ip: core::net::Ipv4Addr) -> bool {
        if self.at(index).is_none() || self.own_address(index, Some(ip)).is_some() {
            return false;
        }
        let Some(list) = self.trusted.get_mut(index) else {
            return false;
        };
        list.rotate_right(1);
        if let Some(first) = list.first_mut() {
            *first = Some(ip);
        }
        true
    }

    /// Sets the own addresses of account `index` (a stored image, a file).
    pub fn set_trusted(&mut self, index: usize, trusted: Trusted) {
        if let Some(t) = self.trusted.get_mut(index) {
            *t = trusted;
        }
    }

    /// The accounts, in the order they were created.
    pub fn iter(&self) -> impl Iterator<Item = &Account> {
        self.list.iter().flatten()
    }

    /// How many exist.
    pub fn len(&self) -> usize {
        self.iter().count()
    }

    /// `true` if none exists.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// `true` if an administrator exists.
    pub fn admin_exists(&self) -> bool {
        self.iter().any(|a| a.role == Role::Admin)
    }

    /// The account named `name`.
    pub fn get(&self, name: &[u8]) -> Option<&Account> {
        self.iter().find(|a| a.name.as_bytes() == name)
    }

    /// Its index (kept while it exists: sessions and the rate limit refer
    /// to accounts by it).
    pub fn index_of(&self, name: &[u8]) -> Option<usize> {
        self.list
            .iter()
            .position(|a| a.is_some_and(|a| a.name.as_bytes() == name))
    }

    /// The account at `index`.
    pub fn at(&self, index: usize) -> Option<&Account> {
        self.list.get(index)?.as_ref()
    }

    /// Adds `account`; returns its index.
    pub fn add(&mut self, account: Account) -> Result<usize, AccountError> {
        if self.get(account.name.as_bytes()).is_some() {
            return Err(AccountError::Exists);
        }
        let i = self
            .list
            .iter()
            .position(Option::is_none)
            .ok_or(AccountError::Full)?;
        if let Some(slot) = self.list.get_mut(i) {
            *slot = Some(account);
        }
        self.set_trusted(i, [None; TRUSTED]);
        Ok(i)
    }

    /// Removes the account named `name`.
    pub fn remove(&mut self, name: &[u8]) -> Result<Account, AccountError> {
        let i = self.index_of(name).ok_or(AccountError::Unknown)?;
        self.check_admin_left(i, None)?;
        self.set_trusted(i, [None; TRUSTED]);
        self.list
            .get_mut(i)
            .and_then(Option::take)
            .ok_or(AccountError::Unknown)
    }

    /// Gives the account named `name` the role `role`.
    pub fn set_role(&mut self, name: &[u8], role: Role) -> Result<(), AccountError> {
        let i = self.index_of(name).ok_or(AccountError::Unknown)?;
        self.check_admin_left(i, Some(role))?;
        let a = self
            .list
            .get_mut(i)
            .and_then(Option::as_mut)
            .ok_or(AccountError::Unknown)?;
        a.role = role;
        Ok(())
    }

    /// Gives the account named `name` a new password hash. Its own
    /// addresses are forgotten (someone who knew the old password may have
    /// logged in from theirs): the caller trusts the address the change
    /// came from again, if it is the account's owner's.
    pub fn set_hash(&mut self, name: &[u8], hash: PasswordHash) -> Result<(), AccountError> {
        let i = self.index_of(name).ok_or(AccountError::Unknown)?;
        let a = self
            .list
            .get_mut(i)
            .and_then(Option::as_mut)
            .ok_or(AccountError::Unknown)?;
        a.hash = hash;
        self.set_trusted(i, [None; TRUSTED]);
        Ok(())
    }

    /// Refuses a change of account `i` to `role` (`None`: removed) that
    /// would leave no administrator.
    fn check_admin_left(&self, i: usize, role: Option<Role>) -> Result<(), AccountError> {
        let was_admin = self.at(i).is_some_and(|a| a.role == Role::Admin);
        let others = self
            .list
            .iter()
            .enumerate()
            .filter(|(k, a)| *k != i && a.is_some_and(|a| a.role == Role::Admin))
            .count();
        if was_admin && role != Some(Role::Admin) && others == 0 {
            return Err(AccountError::LastAdmin);
        }
        Ok(())
    }
}

#[cfg(all(test, feature = "web"))]
mod tests {
    use super::*;
    use crate::access::password::{HASH_LEN, SALT_LEN};

    fn hash(n: u8) -> PasswordHash {
        PasswordHash {
            iterations: 10,
            salt: [n; SALT_LEN],
            hash: [n; HASH_LEN],
        }
    }

    fn account(name: &str, role: Role) -> Account {
        Account {
            name: UserName::new(name.as_bytes()).unwrap(),
            role,
            hash: hash(name.len() as u8),
        }
    }

    #[test]
    fn names_follow_the_rules() {
        for ok in ["a", "admin", "op.2", "line-3_cell", "abcdefghijklmnop"] {
            assert_eq!(UserName::new(ok.as_bytes()).unwrap().as_str(), ok);
        }
        for bad in [
            "",
            "Admin",
            "1st",
            "a b",
            "a\"b",
            "a,b",
            "abcdefghijklmnopq",
            "é",
            "<s>",
        ] {
            assert!(UserName::new(bad.as_bytes()).is_none(), "{bad:?}");
        }
    }

    #[test]
    fn the_last_administrator_stays() {
        let mut a = Accounts::NONE;
        assert!(!a.admin_exists());
        a.add(account("root", Role::Admin)).unwrap();
        a.add(account("view", Role::Viewer)).unwrap();
        assert_eq!(
            a.add(account("view", Role::Operator)),
            Err(AccountError::Exists)
        );
        assert_eq!(a.remove(b"root"), Err(AccountError::LastAdmin));
        assert_eq!(
            a.set_role(b"root", Role::Operator),
            Err(AccountError::LastAdmin)
        );
        a.set_role(b"view", Role::Admin).unwrap();
        a.set_role(b"root", Role::Operator).unwrap();
        assert_eq!(a.remove(b"view"), Err(AccountError::LastAdmin));
        assert!(a.remove(b"root").is_ok());
        assert_eq!(a.remove(b"root"), Err(AccountError::Unknown));
        assert!(a.admin_exists());
        assert_eq!(a.len(), 1);
    }

    #[test]
    fn eight_accounts_at_most_and_indexes_are_kept() {
        let mut a = Accounts::NONE;
        let names = ["a0", "a1", "a2", "a3", "a4", "a5", "a6", "a7"];
        for n in names {
            a.add(account(n, Role::Admin)).unwrap();
        }
        assert_eq!(a.add(account("a8", Role::Viewer)), Err(AccountError::Full));
        a.remove(b"a3").unwrap();
        assert_eq!(a.index_of(b"a4"), Some(4));
        assert_eq!(a.add(account("a8", Role::Viewer)), Ok(3));
    }

    #[test]
    fn an_account_survives_its_stored_form() {
        let acc = account("cell-7.op", Role::Operator);
        let b = acc.to_bytes();
        assert_eq!(Account::from_bytes(&b), Some(acc));
        let mut bad_role = b;
        bad_role[1 + NAME_MAX] = 9;
        assert_eq!(Account::from_bytes(&bad_role), None);
        let mut bad_len = b;
        bad_len[0] = 0;
        assert_eq!(Account::from_bytes(&bad_len), None);
        let mut bad_name = b;
        bad_name[1] = b'A';
        assert_eq!(Account::from_bytes(&bad_name), None);
        assert_eq!(Account::from_bytes(&b[..10]), None);
    }
}
