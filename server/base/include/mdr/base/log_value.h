// Client-supplied text (session names and ids, request ids, metadata, field-mask paths) made safe
// to show, in one place: in a key=value log line no client value can start a new line or forge a
// key, and neither a log line nor an error message carries more than a bounded prefix of it.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

namespace mdr {

// Bytes of a client value shown at most; longer values are cut and end in "...(N bytes)".
inline constexpr std::size_t kMaxShownValueBytes = 128;
// Bytes of an error message logged at most: messages are ours and quote client values already
// bounded, so this only keeps a line short whatever a message holds.
inline constexpr std::size_t kMaxLoggedErrorBytes = 1024;

// The value as one logfmt token: bare when it is 1..max_bytes bytes of [A-Za-z0-9._/:@+-] (a
// valid session name, say), else double-quoted with \" \\ \n \r \t and \xNN for every other
// byte outside printable ASCII, cut after max_bytes bytes of the value.
std::string LogValue(std::string_view value, std::size_t max_bytes = kMaxShownValueBytes);

// The value for an error message: always double-quoted, escaped and cut as by LogValue.
std::string Quoted(std::string_view value, std::size_t max_bytes = kMaxShownValueBytes);

}  // namespace mdr
