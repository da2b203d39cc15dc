//! The validation layer's side of the context: the layer's name, and the debug messenger's
//! callback, which logs what the layer says and keeps its warnings and errors for the tests
//! (`GpuContext::validation_messages`).

use std::ffi::{c_void, CStr};
use std::sync::{Arc, Mutex};

use ash::vk;

use super::lock::lock;

/// The Khronos validation layer.
pub(crate) const VALIDATION_LAYER: &CStr = c"VK_LAYER_KHRONOS_validation";

/// Validation messages collected by the debug messenger.
#[derive(Default)]
pub(crate) struct ValidationLog {
    messages: Mutex<Vec<String>>,
}

impl ValidationLog {
    /// Messages of warning or error severity so far.
    pub(crate) fn messages(&self) -> Vec<String> {
        lock(&self.messages).clone()
    }
}

// SAFETY (for the body's dereferences): Vulkan passes `data` null or valid for the call,
// and `user` is null or the `ValidationLog` that the context keeps (an Arc) until it
// destroys the messenger.
unsafe extern "system" fn debug_callback(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    kind: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user: *mut c_void,
) -> vk::Bool32 {
    let message = if data.is_null() || (*data).p_message.is_null() {
        "(no message)".to_string()
    } else {
        CStr::from_ptr((*data).p_message).to_string_lossy().into_owned()
    };
    let serious = severity.intersects(
        vk::DebugUtilsMessageSeverityFlagsEXT::WARNING
            | vk::DebugUtilsMessageSeverityFlagsEXT::ERROR,
    );
    if serious
        && kind.intersects(
            vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
        )
    {
        log::error!("Vulkan validation: {message}");
        if !user.is_null() {
            let log = &*(user as *const ValidationLog);
            lock(&log.messages).push(message);
        }
    } else {
        log::debug!("Vulkan: {message}");
    }
    vk::FALSE
}

/// The messenger's create info: every severity from INFO up goes to [`debug_callback`],
/// with `log` as its user data. The caller keeps `log` alive until it destroys the
/// messenger.
pub(crate) fn messenger_info(
    log: &Arc<ValidationLog>,
) -> vk::DebugUtilsMessengerCreateInfoEXT<'static> {
    vk::DebugUtilsMessengerCreateInfoEXT::default()
        .message_severity(
            vk::DebugUtilsMessageSeverityFlagsEXT::WARNING
                | vk::DebugUtilsMessageSeverityFlagsEXT::ERROR
                | vk::DebugUtilsMessageSeverityFlagsEXT::INFO,
        )
        .message_type(
            vk::DebugUtilsMessageTypeFlagsEXT::GENERAL
                | vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
        )
        .pfn_user_callback(Some(debug_callback))
        .user_data(Arc::as_ptr(log) as *mut c_void)
}
