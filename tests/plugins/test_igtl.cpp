// The `igtl` plugin against a small OpenIGTLink peer on 127.0.0.1: poses in
// (TRANSFORM and POSITION, mm), forces out (SENSOR, newton), stale input and
// expired commands give zero force, malformed messages are survived, and the
// server mode accepts a peer.

#include "devices/loader.h"

#include <gtest/gtest.h>

#include <arpa/inet.h>
#include <igtlMessageHeader.h>
#include <igtlPositionMessage.h>
#include <igtlSensorMessage.h>
#include <igtlTransformMessage.h>
#include <igtlUnit.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <optional>
#include <thread>
#include <vector>

namespace palpa {
namespace {

using namespace std::chrono_literals;

double now() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

// A blocking TCP peer on the loopback address.
class Peer {
 public:
  ~Peer() {
    if (fd_ >= 0) ::close(fd_);
    if (listen_fd_ >= 0) ::close(listen_fd_);
  }
  // Listens on 127.0.0.1 at a free port; returns it.
  int listen_loopback() {
    listen_fd_ = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    a.sin_port = 0;
    if (bind(listen_fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 || listen(listen_fd_, 1) != 0) return -1;
    socklen_t len = sizeof a;
    getsockname(listen_fd_, reinterpret_cast<sockaddr*>(&a), &len);
    return ntohs(a.sin_port);
  }
  bool accept_one(int timeout_ms) {
    pollfd p{listen_fd_, POLLIN, 0};
    if (poll(&p, 1, timeout_ms) != 1) return false;
    fd_ = accept(listen_fd_, nullptr, nullptr);
    return fd_ >= 0;
  }
  bool connect_loopback(int port) {
    fd_ = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    a.sin_port = htons(static_cast<std::uint16_t>(port));
    return connect(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
  }
  void send_bytes(const void* data, std::size_t n) { ASSERT_EQ(::send(fd_, data, n, MSG_NOSIGNAL), ssize_t(n)); }
  void send(igtl::MessageBase* m) { send_bytes(m->GetPackPointer(), static_cast<std::size_t>(m->GetPackSize())); }

  // Receives exactly n bytes (false on timeout or close).
  bool receive(void* data, std::size_t n, int timeout_ms = 1000) {
    auto* p = static_cast<std::uint8_t*>(data);
    while (n > 0) {
      pollfd q{fd_, POLLIN, 0};
      if (poll(&q, 1, timeout_ms) != 1) return false;
      const ssize_t got = ::recv(fd_, p, n, 0);
      if (got <= 0) return false;
      p += got;
      n -= static_cast<std::size_t>(got);
    }
    return true;
  }

  // The next SENSOR message: its device name, unit and three values.
  struct Sensor {
    std::string name;
    igtl::igtlUnit unit = 0;
    double v[3] = {0, 0, 0};
  };
  std::optional<Sensor> next_sensor() {
    for (int i = 0; i < 1000; ++i) {
      igtl::MessageHeader::Pointer h = igtl::MessageHeader::New();
      h->InitPack();
      if (!receive(h->GetPackPointer(), static_cast<std::size_t>(h->GetPackSize()))) return std::nullopt;
      h->Unpack();
      std::vector<std::uint8_t> body(static_cast<std::size_t>(h->GetBodySizeToRead()));
      if (!receive(body.data(), body.size())) return std::nullopt;
      if (std::string(h->GetDeviceType()) != "SENSOR") continue;
      igtl::SensorMessage::Pointer s = igtl::SensorMessage::New();
      s->SetMessageHeader(h);
      s->AllocatePack();
      std::memcpy(s->GetPackBodyPointer(), body.data(), body.size());
      if (!(s->Unpack(1) & igtl::MessageHeader::UNPACK_BODY) || s->GetLength() != 3) return std::nullopt;
      Sensor out;
      out.name = h->GetDeviceName();
      out.unit = s->GetUnit();
      for (unsigned k = 0; k < 3; ++k) out.v[k] = s->GetValue(k);
      return out;
    }
    return std::nullopt;
  }
  // The latest SENSOR after draining for `ms`.
  std::optional<Sensor> latest_sensor(int ms) {
    std::optional<Sensor> last;
    const double end = now() + ms * 1e-3;
    while (now() < end)
      if (auto s = next_sensor()) last = s;
    return last;
  }

 private:
  int listen_fd_ = -1, fd_ = -1;
};

igtl::TransformMessage::Pointer transform(const char* name, double x_mm, double y_mm, double z_mm, double angle) {
  igtl::TransformMessage::Pointer m = igtl::TransformMessage::New();
  m->SetDeviceName(name);
  igtl::Matrix4x4 t;
  igtl::IdentityMatrix(t);
  // Rotation about z by `angle`.
  t[0][0] = static_cast<float>(std::cos(angle));
  t[0][1] = static_cast<float>(-std::sin(angle));
  t[1][0] = static_cast<float>(std::sin(angle));
  t[1][1] = static_cast<float>(std::cos(angle));
  t[0][3] = static_cast<float>(x_mm);
  t[1][3] = static_cast<float>(y_mm);
  t[2][3] = static_cast<float>(z_mm);
  m->SetMatrix(t);
  m->Pack();
  return m;
}

igtl::igtlUnit newton() {
  igtl::Unit::Pointer u = igtl::Unit::New();
  u->Init();
  u->SetPrefix(igtl::Unit::SI_PREFIX_NONE);
  u->Append(igtl::Unit::SI_DERIVED_NEWTON, 1);
  return u->Pack();
}

devices::Device make(const std::string& options) {
  devices::Device d = devices::PluginLoader({PALPA_PLUGIN_DIR}).load("igtl").create(options);
  d.start();
  return d;
}

template <class Pred>
bool wait_for(Pred p, double seconds = 2.0) {
  const double end = now() + seconds;
  while (now() < end) {
    if (p()) return true;
    std::this_thread::sleep_for(1ms);
  }
  return p();
}

TEST(IgtlPlugin, ReceivesPosesAndSendsForcesAsAClient) {
  Peer peer;
  const int port = peer.listen_loopback();
  ASSERT_GT(port, 0);
  devices::Device d = make("mode=client;host=127.0.0.1;port=" + std::to_string(port) + ";stale_after=0.2");
  EXPECT_EQ(d.spec().force_dof, 3u);
  ASSERT_TRUE(peer.accept_one(2000));

  // TRANSFORM: 10, 20, 30 mm and 90 degrees about z.
  auto m = transform("Tracker", 10, 20, 30, std::numbers::pi / 2);
  peer.send(m.GetPointer());
  PalpaDeviceSample s;
  ASSERT_TRUE(wait_for([&] { return d.read(s) && (s.status & PALPA_STATUS_VALID); }));
  EXPECT_NEAR(s.position[0], 0.010, 1e-7);
  EXPECT_NEAR(s.position[1], 0.020, 1e-7);
  EXPECT_NEAR(s.position[2], 0.030, 1e-7);
  EXPECT_NEAR(s.orientation[0], std::cos(std::numbers::pi / 4), 1e-6);  // w
  EXPECT_NEAR(s.orientation[3], std::sin(std::numbers::pi / 4), 1e-6);  // z
  EXPECT_EQ(s.status, PALPA_STATUS_VALID);

  // POSITION: -5, 0, 12.5 mm with identity orientation.
  igtl::PositionMessage::Pointer pm = igtl::PositionMessage::New();
  pm->SetDeviceName("Tracker");
  pm->SetPosition(-5.f, 0.f, 12.5f);
  pm->SetQuaternion(0.f, 0.f, 0.f, 1.f);
  pm->Pack();
  peer.send(pm.GetPointer());
  ASSERT_TRUE(wait_for([&] { return d.read(s) && std::abs(s.position[0] + 0.005) < 1e-9; }));
  EXPECT_NEAR(s.position[2], 0.0125, 1e-9);
  EXPECT_NEAR(s.orientation[0], 1.0, 1e-9);

  // The force goes back as SENSOR in newtons while the pose is fresh.
  PalpaForceCommand c{};
  c.force[0] = 1.0;
  c.force[1] = -2.0;
  c.force[2] = 0.5;
  c.time = now();
  c.expires_after = 10.0;
  ASSERT_TRUE(d.write(c));
  peer.send(pm.GetPointer());  // keep the pose fresh
  auto f = peer.latest_sensor(50);
  ASSERT_TRUE(f.has_value());
  EXPECT_EQ(f->name, "PalpaForce");
  EXPECT_EQ(f->unit, newton());
  EXPECT_EQ(f->v[0], 1.0);
  EXPECT_EQ(f->v[1], -2.0);
  EXPECT_EQ(f->v[2], 0.5);

  // No more poses: stale after 0.2 s, and the force sent back is zero.
  std::this_thread::sleep_for(300ms);
  d.read(s);
  EXPECT_TRUE(s.status & PALPA_STATUS_STALE);
  f = peer.latest_sensor(50);
  ASSERT_TRUE(f.has_value());
  EXPECT_EQ(f->v[0], 0.0);
  EXPECT_EQ(f->v[1], 0.0);
  EXPECT_EQ(f->v[2], 0.0);

  // Fresh pose but an expired command (the loop's watchdog): zero too.
  c.time = now() - 1.0;
  c.expires_after = 0.01;
  d.write(c);
  for (int i = 0; i < 5; ++i) {
    peer.send(pm.GetPointer());
    std::this_thread::sleep_for(10ms);
  }
  f = peer.latest_sensor(20);
  ASSERT_TRUE(f.has_value());
  EXPECT_EQ(f->v[0], 0.0);
}

TEST(IgtlPlugin, SurvivesMalformedMessagesAndFiltersByDeviceName) {
  Peer peer;
  const int port = peer.listen_loopback();
  devices::Device d = make("port=" + std::to_string(port) + ";device=Stylus;stale_after=5");
  ASSERT_TRUE(peer.accept_one(2000));
  // Another device's pose is ignored.
  auto other = transform("Reference", 100, 0, 0, 0);
  peer.send(other.GetPointer());
  // A TRANSFORM whose body was damaged: the CRC check fails, it is ignored.
  auto bad = transform("Stylus", 1, 2, 3, 0);
  static_cast<std::uint8_t*>(bad->GetPackBodyPointer())[5] ^= 0xff;
  peer.send(bad.GetPointer());
  // Then a good one.
  auto good = transform("Stylus", 7, 8, 9, 0);
  peer.send(good.GetPointer());
  PalpaDeviceSample s;
  ASSERT_TRUE(wait_for([&] { return d.read(s) && (s.status & PALPA_STATUS_VALID); }));
  EXPECT_NEAR(s.position[0], 0.007, 1e-7);
  EXPECT_EQ(s.sequence, 1u);  // exactly one accepted pose
  EXPECT_EQ(d.message(), "igtl: refused a TRANSFORM message: its CRC does not match its body (1 bad so far)");
}

TEST(IgtlPlugin, ServerModeAcceptsAPeerOnLoopback) {
  devices::Device d = make("mode=server;host=127.0.0.1;port=0;unit=m");
  const std::string msg = d.message();
  const std::string prefix = "igtl: listening on 127.0.0.1:";
  ASSERT_EQ(msg.substr(0, prefix.size()), prefix) << msg;
  const int port = std::stoi(msg.substr(prefix.size()));
  Peer peer;
  ASSERT_TRUE(peer.connect_loopback(port));
  auto m = transform("Probe", 0.05, -0.01, 0.2, 0);  // metres this time
  peer.send(m.GetPointer());
  PalpaDeviceSample s;
  ASSERT_TRUE(wait_for([&] { return d.read(s) && (s.status & PALPA_STATUS_VALID); }));
  EXPECT_NEAR(s.position[0], 0.05, 1e-7);
  EXPECT_NEAR(s.position[2], 0.2, 1e-7);
}

// One idle peer that sends half a header no longer locks the real tracker out.
TEST(IgtlPlugin, AnIdlePeerIsReplacedByTheNextOneAfterTheTimeout) {
  devices::Device d = make("mode=server;host=127.0.0.1;port=0;unit=m;peer_timeout=0.2");
  const std::string msg = d.message();
  const int port = std::stoi(msg.substr(std::string("igtl: listening on 127.0.0.1:").size()));
  Peer idle, tracker;
  ASSERT_TRUE(idle.connect_loopback(port));
  const std::uint8_t half[20] = {0, 1, 'T', 'R', 'A', 'N', 'S'};
  idle.send_bytes(half, sizeof half);
  ASSERT_TRUE(wait_for([&] { return d.message().find("connected") != std::string::npos; }));
  ASSERT_TRUE(tracker.connect_loopback(port));
  ASSERT_TRUE(wait_for([&] { return d.message().find("replaced a peer idle for") != std::string::npos; }))
      << d.message();
  auto m = transform("Probe", 0.05, 0, 0, 0);
  tracker.send(m.GetPointer());
  PalpaDeviceSample s;
  ASSERT_TRUE(wait_for([&] { return d.read(s) && (s.status & PALPA_STATUS_VALID); }));
  EXPECT_NEAR(s.position[0], 0.05, 1e-7);
}

// Listening on every address is allowed when asked for, and said with a warning.
TEST(IgtlPlugin, ListeningOnAllAddressesCarriesAWarning) {
  devices::Device d = make("mode=server;host=0.0.0.0;port=0");
  const std::string msg = d.message();
  const std::string warning =
      " (warning: listening on all addresses, so any computer that reaches this one can send poses)";
  ASSERT_EQ(msg.rfind("igtl: listening on 0.0.0.0:", 0), 0u) << msg;
  EXPECT_EQ(msg.substr(msg.size() - warning.size()), warning);
  // The default is the loopback address, with no warning.
  devices::Device local = make("mode=server;port=0");
  EXPECT_EQ(local.message().rfind("igtl: listening on 127.0.0.1:", 0), 0u);
  EXPECT_EQ(local.message().find("warning"), std::string::npos);
}

TEST(IgtlPlugin, OptionErrors) {
  const devices::Plugin p = devices::PluginLoader({PALPA_PLUGIN_DIR}).load("igtl");
  auto message = [&](const std::string& o) {
    try {
      p.create(o);
    } catch (const devices::DeviceError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(message("mode=peer"), "igtl: option mode='peer' must be client or server");
  EXPECT_EQ(message("host=localhost"), "igtl: option host='localhost' is not an IPv4 address");
  EXPECT_EQ(message("unit=inch"), "igtl: option unit='inch' must be mm or m");
  EXPECT_EQ(message("port=0"), "igtl: option port=0 is outside [1, 65535]");
}

}  // namespace
}  // namespace palpa
