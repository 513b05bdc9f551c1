//! Who gets in and what they may do: anonymous sessions where an endpoint allows them (only
//! the `None` endpoint on loopback, [`crate::security`]), users by name and password on the
//! encrypted endpoints only; every user reads and calls `ResultManagement`'s methods, nobody
//! writes anything. Password checks run on blocking threads, at most [`CHECKS`] at a time
//! (each may take tens of MiB), so a crowd of logins cannot exhaust the machine.

use crate::users::Users;
use async_trait::async_trait;
use opcua::crypto::SecurityPolicy;
use opcua::server::ANONYMOUS_USER_TOKEN_ID;
use opcua::server::ServerEndpoint;
use opcua::server::address_space::AccessLevel;
use opcua::server::authenticator::{
    AuthManager, Password, UserToken, user_pass_security_policy_id, user_pass_security_policy_uri,
};
use opcua::types::{Error, MethodId, NodeId, StatusCode, UAString, UserTokenPolicy, UserTokenType};
use std::sync::{Arc, OnceLock};
use tokio::sync::Semaphore;

/// Password checks at once.
pub(crate) const CHECKS: usize = 2;

/// The server's authenticator.
pub(crate) struct Auth {
    users: Option<Arc<Users>>,
    /// The methods anyone logged in may call (`ResultManagement`'s, known once the server
    /// is built).
    methods: OnceLock<Vec<NodeId>>,
    checks: Semaphore,
}

impl Auth {
    /// An authenticator for `users` that allows no method calls until
    /// [`Auth::allow_methods`] (but the server's own read-only methods).
    pub(crate) fn new(users: Option<Arc<Users>>) -> Auth {
        Auth {
            users,
            methods: OnceLock::new(),
            checks: Semaphore::new(CHECKS),
        }
    }

    /// Allows calls of `methods`.
    pub(crate) fn allow_methods(&self, methods: Vec<NodeId>) {
        let _ = self.methods.set(methods);
    }
}

fn rejected(why: &str) -> Error {
    Error::new(StatusCode::BadIdentityTokenRejected, why.to_string())
}

/// An endpoint protected by encryption.
fn encrypted(endpoint: &ServerEndpoint) -> bool {
    endpoint.security_policy() != SecurityPolicy::None && endpoint.security_mode == "SignAndEncrypt"
}

#[async_trait]
impl AuthManager for Auth {
    async fn authenticate_anonymous_token(&self, endpoint: &ServerEndpoint) -> Result<(), Error> {
        if endpoint.user_token_ids.contains(ANONYMOUS_USER_TOKEN_ID) {
            Ok(())
        } else {
            Err(rejected("anonymous access is not allowed on this endpoint"))
        }
    }

    async fn authenticate_username_identity_token(
        &self,
        endpoint: &ServerEndpoint,
        username: &str,
        password: &Password,
    ) -> Result<UserToken, Error> {
        let Some(users) = self.users.clone() else {
            return Err(rejected("no users are configured"));
        };
        if !encrypted(endpoint) {
            return Err(rejected(
                "user names are accepted on encrypted endpoints only",
            ));
        }
        let _permit = self
            .checks
            .acquire()
            .await
            .map_err(|_| rejected("the server is stopping"))?;
        let (name, pw) = (username.to_string(), password.get().to_string());
        let ok = tokio::task::spawn_blocking(move || users.verify(&name, &pw))
            .await
            .unwrap_or(false);
        if ok {
            Ok(UserToken(username.to_string()))
        } else {
            Err(rejected("wrong user name or password"))
        }
    }

    fn effective_user_access_level(
        &self,
        _token: &UserToken,
        user_access_level: AccessLevel,
        _node_id: &NodeId,
    ) -> AccessLevel {
        user_access_level
            & !(AccessLevel::CURRENT_WRITE
                | AccessLevel::HISTORY_WRITE
                | AccessLevel::STATUS_WRITE
                | AccessLevel::TIMESTAMP_WRITE)
    }

    fn is_user_executable(&self, _token: &UserToken, method_id: &NodeId) -> bool {
        self.methods.get().is_some_and(|m| m.contains(method_id))
            || *method_id == NodeId::from(MethodId::Server_GetMonitoredItems)
            || *method_id == NodeId::from(MethodId::Server_ResendData)
    }

    fn user_token_policies(&self, endpoint: &ServerEndpoint) -> Vec<UserTokenPolicy> {
        let mut out = Vec::new();
        if endpoint.user_token_ids.contains(ANONYMOUS_USER_TOKEN_ID) {
            out.push(UserTokenPolicy {
                policy_id: UAString::from("anonymous"),
                token_type: UserTokenType::Anonymous,
                issued_token_type: UAString::null(),
                issuer_endpoint_url: UAString::null(),
                security_policy_uri: UAString::null(),
            });
        }
        if self.users.is_some() && encrypted(endpoint) {
            out.push(UserTokenPolicy {
                policy_id: user_pass_security_policy_id(endpoint),
                token_type: UserTokenType::UserName,
                issued_token_type: UAString::null(),
                issuer_endpoint_url: UAString::null(),
                security_policy_uri: user_pass_security_policy_uri(endpoint),
            });
        }
        out
    }
}
