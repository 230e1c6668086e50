// Who makes a call: the principal (token name) when authentication is on; nullopt when it is
// off, and then every caller sees every session and new sessions belong to no one (owner "").
#pragma once

#include <optional>
#include <string>

namespace mdr::service {

using Principal = std::optional<std::string>;

}  // namespace mdr::service
