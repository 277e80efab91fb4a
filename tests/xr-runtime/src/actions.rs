//! Paths and actions: the simulated Oculus Touch controllers' thumbsticks and buttons.

use crate::*;
use openxr_sys as xr;

// ---- paths and actions ----------------------------------------------------------------------

pub(crate) unsafe extern "system" fn string_to_path(
    instance: xr::Instance,
    string: *const c_char,
    path: *mut xr::Path,
) -> xr::Result {
    let mut rt = runtime();
    if !rt.instance_ok(instance) {
        return xr::Result::ERROR_HANDLE_INVALID;
    }
    let s = CStr::from_ptr(string).to_string_lossy().into_owned();
    if !s.starts_with('/') || s.ends_with('/') || s.contains("//") {
        return xr::Result::ERROR_PATH_FORMAT_INVALID;
    }
    let index = match rt.paths.iter().position(|p| *p == s) {
        Some(i) => i,
        None => {
            rt.paths.push(s);
            rt.paths.len() - 1
        }
    };
    *path = xr::Path::from_raw(index as u64);
    xr::Result::SUCCESS
}

pub(crate) unsafe extern "system" fn path_to_string(
    instance: xr::Instance,
    path: xr::Path,
    capacity: u32,
    count: *mut u32,
    buffer: *mut c_char,
) -> xr::Result {
    let rt = runtime();
    if !rt.instance_ok(instance) {
        return xr::Result::ERROR_HANDLE_INVALID;
    }
    let Some(s) = rt
        .paths
        .get(path.into_raw() as usize)
        .filter(|_| path.into_raw() != 0)
    else {
        return xr::Result::ERROR_PATH_INVALID;
    };
    let bytes: Vec<u8> = s.bytes().chain(std::iter::once(0)).collect();
    two_call(capacity, count, buffer, bytes.len(), |i, c| {
        *c = bytes[i] as c_char
    })
}

pub(crate) unsafe extern "system" fn create_action_set(
    instance: xr::Instance,
    info: *const xr::ActionSetCreateInfo,
    set: *mut xr::ActionSet,
) -> xr::Result {
    let mut rt = runtime();
    if !rt.instance_ok(instance) {
        return xr::Result::ERROR_HANDLE_INVALID;
    }
    let name = read_str(&(*info).action_set_name);
    if name.is_empty() || rt.action_sets.values().any(|n| *n == name) {
        return xr::Result::ERROR_NAME_DUPLICATED;
    }
    let h = rt.handle();
    rt.action_sets.insert(h, name);
    *set = xr::ActionSet::from_raw(h);
    xr::Result::SUCCESS
}

pub(crate) unsafe extern "system" fn destroy_action_set(set: xr::ActionSet) -> xr::Result {
    let mut rt = runtime();
    rt.actions.retain(|_, (s, _, _)| *s != set.into_raw());
    match rt.action_sets.remove(&set.into_raw()) {
        Some(_) => xr::Result::SUCCESS,
        None => xr::Result::ERROR_HANDLE_INVALID,
    }
}

pub(crate) unsafe extern "system" fn create_action(
    set: xr::ActionSet,
    info: *const xr::ActionCreateInfo,
    action: *mut xr::Action,
) -> xr::Result {
    let mut rt = runtime();
    if !rt.action_sets.contains_key(&set.into_raw()) {
        return xr::Result::ERROR_HANDLE_INVALID;
    }
    if rt.sessions.values().any(|s| s.attached) {
        return xr::Result::ERROR_ACTIONSETS_ALREADY_ATTACHED;
    }
    let h = rt.handle();
    rt.actions
        .insert(h, (set.into_raw(), (*info).action_type, Vec::new()));
    *action = xr::Action::from_raw(h);
    xr::Result::SUCCESS
}

pub(crate) unsafe extern "system" fn destroy_action(action: xr::Action) -> xr::Result {
    match runtime().actions.remove(&action.into_raw()) {
        Some(_) => xr::Result::SUCCESS,
        None => xr::Result::ERROR_HANDLE_INVALID,
    }
}

pub(crate) unsafe extern "system" fn suggest_interaction_profile_bindings(
    instance: xr::Instance,
    info: *const xr::InteractionProfileSuggestedBinding,
) -> xr::Result {
    let mut rt = runtime();
    if !rt.instance_ok(instance) {
        return xr::Result::ERROR_HANDLE_INVALID;
    }
    let info = &*info;
    let Some(profile) = rt
        .paths
        .get(info.interaction_profile.into_raw() as usize)
        .cloned()
    else {
        return xr::Result::ERROR_PATH_INVALID;
    };
    if !profile.starts_with("/interaction_profiles/") {
        return xr::Result::ERROR_PATH_UNSUPPORTED;
    }
    let mut bindings = Vec::new();
    for i in 0..info.count_suggested_bindings as usize {
        let b = &*info.suggested_bindings.add(i);
        let Some(path) = rt.paths.get(b.binding.into_raw() as usize).cloned() else {
            return xr::Result::ERROR_PATH_INVALID;
        };
        if !path.starts_with("/user/hand/") {
            return xr::Result::ERROR_PATH_UNSUPPORTED;
        }
        if !rt.actions.contains_key(&b.action.into_raw()) {
            return xr::Result::ERROR_HANDLE_INVALID;
        }
        bindings.push((b.action.into_raw(), path));
    }
    // the simulated controllers are Oculus Touch: only that profile's bindings take effect
    if profile == PROFILE {
        for (action, path) in bindings {
            if let Some(a) = rt.actions.get_mut(&action) {
                a.2.push(path);
            }
        }
    }
    xr::Result::SUCCESS
}

pub(crate) unsafe extern "system" fn attach_session_action_sets(
    session: xr::Session,
    _info: *const xr::SessionActionSetsAttachInfo,
) -> xr::Result {
    let mut rt = runtime();
    let Some(s) = rt.sessions.get_mut(&session.into_raw()) else {
        return xr::Result::ERROR_HANDLE_INVALID;
    };
    if s.attached {
        return xr::Result::ERROR_ACTIONSETS_ALREADY_ATTACHED;
    }
    s.attached = true;
    xr::Result::SUCCESS
}

pub(crate) unsafe extern "system" fn sync_actions(
    session: xr::Session,
    _info: *const xr::ActionsSyncInfo,
) -> xr::Result {
    let rt = runtime();
    let Some(s) = rt.sessions.get(&session.into_raw()) else {
        return xr::Result::ERROR_HANDLE_INVALID;
    };
    if !s.attached {
        return xr::Result::ERROR_ACTIONSET_NOT_ATTACHED;
    }
    if s.state != xr::SessionState::FOCUSED {
        return xr::Result::SESSION_NOT_FOCUSED;
    }
    xr::Result::SUCCESS
}

pub(crate) fn bound_value(
    rt: &Runtime,
    action: xr::Action,
    ty: xr::ActionType,
) -> Result<Option<[f32; 2]>, xr::Result> {
    let Some((_, action_type, bindings)) = rt.actions.get(&action.into_raw()) else {
        return Err(xr::Result::ERROR_HANDLE_INVALID);
    };
    if *action_type != ty {
        return Err(xr::Result::ERROR_ACTION_TYPE_MISMATCH);
    }
    let focused = rt
        .sessions
        .values()
        .any(|s| s.state == xr::SessionState::FOCUSED);
    let Some(binding) = bindings.first().filter(|_| focused) else {
        return Ok(None);
    };
    let value = if binding == "/user/hand/left/input/thumbstick" {
        env_pair("VLF_TEST_XR_LEFT_STICK", [0.0, 0.0])
    } else if binding == "/user/hand/right/input/thumbstick" {
        env_pair("VLF_TEST_XR_RIGHT_STICK", [0.0, 0.0])
    } else {
        [0.0, 0.0]
    };
    Ok(Some(value))
}

pub(crate) unsafe extern "system" fn get_action_state_vector2f(
    session: xr::Session,
    info: *const xr::ActionStateGetInfo,
    state: *mut xr::ActionStateVector2f,
) -> xr::Result {
    let rt = runtime();
    if !rt.sessions.contains_key(&session.into_raw()) {
        return xr::Result::ERROR_HANDLE_INVALID;
    }
    match bound_value(&rt, (*info).action, xr::ActionType::VECTOR2F_INPUT) {
        Err(e) => e,
        Ok(v) => {
            let s = &mut *state;
            s.is_active = v.is_some().into();
            let [x, y] = v.unwrap_or_default();
            s.current_state = xr::Vector2f { x, y };
            s.changed_since_last_sync = xr::FALSE;
            s.last_change_time = xr::Time::from_nanos(0);
            xr::Result::SUCCESS
        }
    }
}

pub(crate) unsafe extern "system" fn get_action_state_boolean(
    session: xr::Session,
    info: *const xr::ActionStateGetInfo,
    state: *mut xr::ActionStateBoolean,
) -> xr::Result {
    let rt = runtime();
    if !rt.sessions.contains_key(&session.into_raw()) {
        return xr::Result::ERROR_HANDLE_INVALID;
    }
    match bound_value(&rt, (*info).action, xr::ActionType::BOOLEAN_INPUT) {
        Err(e) => e,
        Ok(v) => {
            let s = &mut *state;
            s.is_active = v.is_some().into();
            s.current_state = xr::FALSE;
            s.changed_since_last_sync = xr::FALSE;
            s.last_change_time = xr::Time::from_nanos(0);
            xr::Result::SUCCESS
        }
    }
}
