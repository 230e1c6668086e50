// Issue #12: client values in logs and error messages. Every log line the server writes while
// serving hostile names, ids and metadata is captured (spdlog's default logger swapped for one
// writing to a string) and parsed as logfmt: each line must hold exactly the expected keys, so a
// newline or " level=info event=forged" in a client value can neither start a line nor add a key.
// Also: bounded messages for huge names, and the request checks of the issue (Durations, radii,
// scene scales), each asserted by its field and text.
#include <grpcpp/generic/generic_stub.h>
#include <spdlog/sinks/ostream_sink.h>
#include <spdlog/spdlog.h>

#include <future>
#include <memory>
#include <regex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "mdr/base/log_value.h"
#include "mdr/bridge/outputs.h"
#include "service_test_util.h"

namespace mdr::service_testing {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::Not;
using ::testing::StartsWith;

constexpr std::size_t kMaxLineBytes = 2048;
constexpr char kForgery[] = "\nlevel=info event=forged session=sessions/victim";

// The keys of a logfmt line in order; empty if any part of the line is not `key=value` (value
// bare, or double-quoted with backslash escapes) separated by single spaces. *event gets the
// value of the key "event".
std::vector<std::string> LogfmtKeys(const std::string& line, std::string* event) {
  static const std::regex kPair(R"re(([a-z_]+)=("(?:[^"\\]|\\.)*"|[^ "=]+)( |$))re");
  std::vector<std::string> keys;
  auto it = line.cbegin();
  std::smatch match;
  while (it != line.cend()) {
    if (!std::regex_search(it, line.cend(), match, kPair, std::regex_constants::match_continuous)) {
      return {};
    }
    keys.push_back(match[1]);
    if (match[1] == "event") *event = match[2];
    it = match[0].second;
  }
  return keys;
}

TEST(LogValueTest, ValidNamesStayBareEverythingElseIsQuotedAndEscaped) {
  EXPECT_EQ(LogValue("sessions/run-1"), "sessions/run-1");
  EXPECT_EQ(LogValue(""), "\"\"");
  EXPECT_EQ(LogValue("a b"), "\"a b\"");
  EXPECT_EQ(LogValue("x\nlevel=info \"q\" \\"), R"("x\nlevel=info \"q\" \\")");
  EXPECT_EQ(LogValue(std::string("\r\t\x01\x7f\xc3\xa9\0", 7)), R"("\r\t\x01\x7F\xC3\xA9\x00")");
  EXPECT_EQ(Quoted("sessions/run-1"), "\"sessions/run-1\"");
}

TEST(LogValueTest, LongValuesShowABoundedPrefixAndTheirLength) {
  const std::string huge(1 << 20, 'a');
  const std::string shown = LogValue(huge);
  EXPECT_EQ(shown, "\"" + std::string(kMaxShownValueBytes, 'a') + "...(1048576 bytes)\"");
  EXPECT_EQ(Quoted(huge, 4), "\"aaaa...(1048576 bytes)\"");
}

// A server whose log lines (info and debug) are captured, one string per line.
class LogSafetyTest : public ServiceTest {
 protected:
  void SetUp() override {
    previous_ = spdlog::default_logger();
    auto sink = std::make_shared<spdlog::sinks::ostream_sink_mt>(log_);
    auto logger = std::make_shared<spdlog::logger>("captured", sink);
    logger->set_pattern("level=%l %v");
    logger->set_level(spdlog::level::debug);
    spdlog::set_default_logger(logger);
    ServiceTest::SetUp();
  }
  void TearDown() override {
    stub_.reset();
    server_.reset();
    spdlog::set_default_logger(previous_);
  }

  std::vector<std::string> Lines() {
    spdlog::default_logger()->flush();
    std::vector<std::string> lines;
    std::istringstream in(log_.str());
    for (std::string line; std::getline(in, line);) lines.push_back(line);
    return lines;
  }

  // Every captured line is a call line or a session event, with exactly their keys.
  void ExpectOnlyWellFormedLines() {
    const std::vector<std::string> call = {"level",      "rpc",  "session",
                                           "request_id", "code", "seconds"};
    std::vector<std::string> failed_call = call;
    failed_call.push_back("error");
    const std::vector<std::string> event = {"level", "event", "session", "sessions"};
    // StreamApply's close line (written when the stream is done, maybe after Finish returned).
    const std::vector<std::string> stream_closed = {"level", "rpc", "event", "answered"};
    const std::vector<std::string> lines = Lines();
    ASSERT_FALSE(lines.empty());
    for (const std::string& line : lines) {
      // Bounded lines only (a client value is cut at 128 bytes, an error at 1024); a longer one
      // is not parsed (std::regex recurses per character).
      if (line.size() >= kMaxLineBytes) {
        ADD_FAILURE() << "unbounded line of " << line.size() << " bytes: " << line.substr(0, 200);
        continue;
      }
      std::string event_name;
      const std::vector<std::string> keys = LogfmtKeys(line, &event_name);
      EXPECT_TRUE(keys == call || keys == failed_call || keys == event || keys == stream_closed)
          << line;
      if (keys == event) {
        EXPECT_EQ(event_name, "session_created") << line;
      }
      if (keys == stream_closed) {
        EXPECT_EQ(event_name, "closed") << line;
      }
      EXPECT_THAT(line, Not(StartsWith("level=info event=forged")));
    }
  }

  grpc::Status GetSession(const std::string& name, grpc::ClientContext* context) {
    v1::GetSessionRequest request;
    request.set_name(name);
    v1::Session session;
    return stub_->GetSession(context, request, &session);
  }

  std::ostringstream log_;
  std::shared_ptr<spdlog::logger> previous_;
};

TEST_F(LogSafetyTest, ClientValuesCannotForgeLogLines) {
  const std::string session = CreateOrDie("victim");
  // A session name and a session_id carrying a newline and a forged line.
  ExpectInvalidArgument(GetSession(session + kForgery, Context().get()), "name");
  v1::Session created;
  ExpectInvalidArgument(Create(SteelSphereOnSteelFlat(), &created, std::string("x") + kForgery),
                        "session_id");
  v1::ApplyResponse applied;
  ExpectInvalidArgument(Apply(session + kForgery, {DepthStep(kDepth)}, &applied), "session");
  v1::QueryResponse queried;
  ExpectInvalidArgument(Query(session + kForgery, &queried), "session");
  // request_id: printable ids are valid and logged quoted; a newline is refused, logged escaped.
  ASSERT_TRUE(
      Apply(session, {DepthStep(kDepth)}, &applied, {}, "id\" level=info event=forged x=\"").ok());
  ExpectInvalidArgument(Apply(session, {DepthStep(kDepth)}, &applied, {}, kForgery), "request_id");
  // x-request-id metadata (gRPC allows no newline in it; spaces and quotes it does).
  auto context = Context();
  context->AddMetadata("x-request-id", "r1\" level=info event=forged code=\"OK");
  EXPECT_TRUE(GetSession(session, context.get()).ok());

  ExpectOnlyWellFormedLines();
  const std::string log = log_.str();
  EXPECT_THAT(log, HasSubstr(R"(request_id="r1\" level=info event=forged code=\"OK")"));
  EXPECT_THAT(log, HasSubstr(R"(session="sessions/victim\nlevel=info event=forged)"));
}

TEST_F(LogSafetyTest, StreamApplyMessagesCannotForgeLogLines) {
  const std::string session = CreateOrDie("victim");
  auto context = Context();
  context->AddMetadata("x-request-id", "s1 level=info event=forged");
  auto stream = stub_->StreamApply(context.get());
  for (const std::string& target : {session + kForgery, session}) {
    v1::StreamApplyRequest message;
    *message.mutable_apply() = ApplyRequestFor(target, {DepthStep(kDepth)}, {}, "");
    ASSERT_TRUE(stream->Write(message));
    v1::StreamApplyResponse response;
    ASSERT_TRUE(stream->Read(&response));
    EXPECT_EQ(response.status().code(),
              target == session ? grpc::StatusCode::OK : grpc::StatusCode::INVALID_ARGUMENT);
  }
  stream->WritesDone();
  EXPECT_TRUE(stream->Finish().ok());
  ExpectOnlyWellFormedLines();
  EXPECT_THAT(log_.str(), HasSubstr("rpc=StreamApply session=\"sessions/victim\\nlevel=info"));
}

TEST_F(LogSafetyTest, HugeNamesGetAShortInvalidArgumentAndABoundedLogLine) {
  for (std::size_t size : {std::size_t{10} << 10, std::size_t{1} << 20}) {
    const std::string name = "sessions/" + std::string(size, 'a');
    const grpc::Status status = GetSession(name, Context().get());
    ExpectInvalidArgument(status, "name");
    EXPECT_THAT(status.error_message(),
                HasSubstr("...(" + std::to_string(name.size()) + " bytes)"));
    EXPECT_LT(status.error_message().size(), 512u) << status.error_message();

    v1::Session created;
    const grpc::Status create = Create(SteelSphereOnSteelFlat(), &created, std::string(size, 'a'));
    ExpectInvalidArgument(create, "session_id");
    EXPECT_THAT(create.error_message(), HasSubstr("1-63 characters of [a-z0-9-]"));
    EXPECT_LT(create.error_message().size(), 512u);
  }
  ExpectOnlyWellFormedLines();  // which bounds every line
}

TEST_F(LogSafetyTest, FieldMaskPathsAreQuotedBoundedInErrors) {
  const std::string session = CreateOrDie();
  v1::QueryResponse response;
  const grpc::Status status =
      Query(session, &response, {std::string(1000, 'p') + "\"\nlevel=info event=forged"});
  ExpectInvalidArgument(status, "read_mask.paths[0]");
  EXPECT_THAT(status.error_message(), HasSubstr("...(1025 bytes)\" is not a field of"));
  ExpectOnlyWellFormedLines();
}

// Issue #12's request checks, each by its field and text.

// The status of a unary call with raw request bytes.
grpc::Status RawUnaryCall(const std::shared_ptr<grpc::Channel>& channel, const std::string& method,
                          const std::string& bytes) {
  grpc::GenericStub stub(channel);
  grpc::Slice slice(bytes);
  const grpc::ByteBuffer request(&slice, 1);
  grpc::ByteBuffer response;
  std::promise<grpc::Status> done;
  auto context = Context();
  stub.UnaryCall(context.get(), method, grpc::StubOptions(), &request, &response,
                 [&done](grpc::Status status) { done.set_value(std::move(status)); });
  return done.get_future().get();
}

TEST_F(ServiceTest, UnparseableRequestBytesAreInvalidArgumentNamingTheMethod) {
  // Field 1 (name) announces 5 bytes but carries 2.
  const grpc::Status status = RawUnaryCall(channel_, "/mdr.v1.ContactService/GetSession",
                                           std::string("\x0a\x05"
                                                       "ab",
                                                       4));
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << status.error_message();
  EXPECT_THAT(status.error_message(),
              HasSubstr("the request bytes of /mdr.v1.ContactService/GetSession do not parse"));
  // Parsable bytes still reach the handler; an unknown method stays UNIMPLEMENTED.
  ExpectInvalidArgument(RawUnaryCall(channel_, "/mdr.v1.ContactService/GetSession", "\x0a\x01x"),
                        "name");
  EXPECT_EQ(RawUnaryCall(channel_, "/mdr.v1.ContactService/NoSuchMethod", "").error_code(),
            grpc::StatusCode::UNIMPLEMENTED);
}

TEST_F(ServiceTest, IdleTimeoutMustBeANormalizedDuration) {
  v1::CreateSessionRequest request;
  *request.mutable_session()->mutable_scene() = SteelSphereOnSteelFlat();
  google::protobuf::Duration* timeout =
      request.mutable_session()->mutable_limits()->mutable_idle_timeout();
  v1::Session session;
  timeout->set_nanos(1'500'000'000);
  grpc::Status status = stub_->CreateSession(Context().get(), request, &session);
  ExpectInvalidArgument(status, "session.limits.idle_timeout.nanos");
  EXPECT_THAT(status.error_message(), HasSubstr("must be in [0, 999999999]"));
  EXPECT_THAT(status.error_message(), HasSubstr("got 1500000000"));
  timeout->set_nanos(-1);
  ExpectInvalidArgument(stub_->CreateSession(Context().get(), request, &session),
                        "session.limits.idle_timeout.nanos");
  timeout->set_nanos(0);
  timeout->set_seconds(-5);
  status = stub_->CreateSession(Context().get(), request, &session);
  ExpectInvalidArgument(status, "session.limits.idle_timeout.seconds");
  EXPECT_THAT(status.error_message(), HasSubstr("must be in [0, 3155760000], got -5"));
  EXPECT_EQ(server_->session_count(), 0u);
  // The same rule for a snapshot's limits.
  timeout->set_seconds(60);
  ASSERT_TRUE(stub_->CreateSession(Context().get(), request, &session).ok());
  v1::ImportSessionRequest import;
  *import.mutable_snapshot() = ExportOrDie(session.name());
  import.mutable_snapshot()->mutable_limits()->mutable_idle_timeout()->set_nanos(1'500'000'000);
  ExpectInvalidArgument(stub_->ImportSession(Context().get(), import, &session),
                        "snapshot.limits.idle_timeout.nanos");
}

// A timeout too long for the clocks' nanoseconds (issue #27: 18446744074 s wrapped to 0.29 s
// on a server whose sessions never expire) is refused before any conversion; the longest
// accepted one is echoed and does not expire the session.
TEST_F(ServiceTest, IdleTimeoutsBeyondTheClocksAreRefused) {
  service::ServerOptions options = LocalServerOptions();
  options.limits.session_idle_timeout = std::chrono::milliseconds(0);  // never
  Restart(options);
  v1::CreateSessionRequest request;
  *request.mutable_session()->mutable_scene() = SteelSphereOnSteelFlat();
  google::protobuf::Duration* timeout =
      request.mutable_session()->mutable_limits()->mutable_idle_timeout();
  v1::Session session;
  for (std::int64_t seconds :
       {std::int64_t{18446744074}, std::int64_t{9223372037}, service::kMaxIdleTimeoutSeconds + 1}) {
    timeout->set_seconds(seconds);
    const grpc::Status status = stub_->CreateSession(Context().get(), request, &session);
    ExpectInvalidArgument(status, "session.limits.idle_timeout.seconds");
    EXPECT_THAT(status.error_message(), HasSubstr("must be in [0, 3155760000]"));
  }
  EXPECT_EQ(server_->session_count(), 0u);
  timeout->set_seconds(service::kMaxIdleTimeoutSeconds);
  timeout->set_nanos(999'999'999);
  ASSERT_TRUE(stub_->CreateSession(Context().get(), request, &session).ok());
  EXPECT_EQ(session.limits().idle_timeout().seconds(), service::kMaxIdleTimeoutSeconds);
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  v1::GetSessionRequest get;
  get.set_name(session.name());
  v1::Session got;
  EXPECT_TRUE(stub_->GetSession(Context().get(), get, &got).ok());
  EXPECT_GT(got.expire_time().seconds(), session.create_time().seconds() + 3'000'000'000);
  // A snapshot's limits follow the same rule.
  v1::ImportSessionRequest import;
  *import.mutable_snapshot() = ExportOrDie(session.name());
  import.mutable_snapshot()->mutable_limits()->mutable_idle_timeout()->set_seconds(18446744074);
  ExpectInvalidArgument(stub_->ImportSession(Context().get(), import, &got),
                        "snapshot.limits.idle_timeout.seconds");
}

TEST_F(ServiceTest, QueryRadiiAreLimitedByTheResponseSizeBeforeAnyWork) {
  service::ServerOptions options = LocalServerOptions();
  options.limits.max_message_bytes = 64 << 10;
  Restart(options);
  const std::string session = CreateOrDie();
  v1::ApplyResponse applied;
  ASSERT_TRUE(
      Apply(session, {DepthStep(kDepth), DisplacementStep(kDisplacementAt15N)}, &applied).ok());
  const std::vector<std::string> radial = {"springs", "tractions", "pressure"};
  bridge::OutputSelection selection = *bridge::SelectQueryOutputs(Mask(radial));
  const std::size_t max_radii = bridge::MaxRadii(selection, options.limits.max_message_bytes);
  ASSERT_GT(max_radii, 100u);
  const double contact_radius = std::sqrt(kRadius * kDepth);
  std::vector<double> radii(max_radii + 1);
  for (std::size_t i = 0; i < radii.size(); ++i) {
    radii[i] = 0.999 * contact_radius * static_cast<double>(i + 1) / radii.size();
  }
  v1::QueryResponse response;
  grpc::Status status = Query(session, &response, radial, radii);
  ExpectInvalidArgument(status, "radii");
  EXPECT_THAT(status.error_message(),
              HasSubstr("at most " + std::to_string(max_radii) + " radii fit in one response"));
  EXPECT_THAT(status.error_message(), HasSubstr("got " + std::to_string(max_radii + 1)));
  EXPECT_EQ(counters_[bridge::Output::kTractions], 0u);
  EXPECT_EQ(counters_[bridge::Output::kPressure], 0u);
  // The maximum itself fits: the limit and the message size agree.
  radii.pop_back();
  status = Query(session, &response, radial, radii);
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_EQ(response.tractions_size(), static_cast<int>(max_radii));
  EXPECT_LE(response.ByteSizeLong(), static_cast<std::size_t>(options.limits.max_message_bytes));
}

TEST_F(ServiceTest, TransformRadiiAreLimitedByTheResponseSize) {
  v1::TransformRequest request;
  *request.mutable_scene() = SteelSphereOnSteelFlat();
  request.mutable_superposition()->set_depth(kDepth);
  bridge::OutputSelection tractions;
  tractions.add(bridge::Output::kTractions);
  const std::size_t max_radii =
      bridge::MaxRadii(tractions, service::ServiceLimits{}.max_message_bytes);
  request.mutable_radii()->Resize(static_cast<int>(max_radii) + 1, 0.0);
  v1::TransformResponse response;
  const grpc::Status status = stub_->Transform(Context().get(), request, &response);
  ExpectInvalidArgument(status, "radii");
  EXPECT_THAT(status.error_message(), HasSubstr("at most " + std::to_string(max_radii)));
}

TEST_F(ServiceTest, SceneScalesWhoseDerivedQuantitiesOverflowAreNamedAtTheScene) {
  v1::Session session;
  v1::Scene scene = SteelSphereOnSteelFlat();
  scene.mutable_sphere()->set_radius(5e-324);
  grpc::Status status = Create(scene, &session);
  ExpectInvalidArgument(status, "session.scene.sphere.radius");
  EXPECT_THAT(status.error_message(), HasSubstr("must be in [1e-100, 1e+100]"));
  EXPECT_THAT(status.error_message(), HasSubstr("got 4.940656458e-324"));

  scene = SteelSphereOnSteelFlat();
  scene.mutable_elastic_pair()->set_youngs_modulus_1(5e-324);
  status = Create(scene, &session);
  ExpectInvalidArgument(status, "session.scene.elastic_pair.youngs_modulus_1");
  EXPECT_THAT(status.error_message(), Not(HasSubstr("e_star")));

  scene = SteelSphereOnSteelFlat();
  scene.mutable_rigid_on_half_space()->set_shear_modulus(1e300);
  scene.mutable_rigid_on_half_space()->set_poisson_ratio(0.3);
  ExpectInvalidArgument(Create(scene, &session), "session.scene.rigid_on_half_space.shear_modulus");

  scene = SteelSphereOnSteelFlat();
  scene.mutable_cone()->set_slope_angle(5e-324);
  status = Create(scene, &session);
  ExpectInvalidArgument(status, "session.scene.cone.slope_angle");
  EXPECT_THAT(status.error_message(), HasSubstr("must be in [1e-100, pi/2) rad"));
  EXPECT_EQ(server_->session_count(), 0u);
}

}  // namespace
}  // namespace mdr::service_testing
