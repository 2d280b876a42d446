#include <gtest/gtest.h>

#include "Dataflow/Network.h"
#include "TestModules.h"
#include <algorithm>
#include <set>
#include <random>
#include "TestUtil.h"

using namespace tetflow;

namespace {
struct NetworkFixture : ::testing::Test {
  ModuleRegistry reg;
  NetworkFixture() { test::registerTestModules(reg); }
};
} // namespace

TEST_F(NetworkFixture, AddModulesGetsFreshIdsAndDefaults) {
  Network net(reg);
  EXPECT_EQ(net.addModule("Number"), "m1");
  EXPECT_EQ(net.addModule("Number"), "m2");
  EXPECT_EQ(net.addModule("Number", "m7"), "m7");
  EXPECT_EQ(net.addModule("Number"), "m8");
  EXPECT_EQ(std::get<double>(net.requireModule("m1").params.at("value")), 0.0);
  EXPECT_THROW_MSG(net.addModule("Nope"), InputError, "unknown module 'Nope'", "CreatePhantom");
  EXPECT_THROW_MSG(net.addModule("Number", "m1"), InputError, "'m1'", "twice");
}

TEST_F(NetworkFixture, ParametersAreValidated) {
  Network net(reg);
  const auto id = net.addModule("CreatePhantom");
  net.setParameterText(id, "voxel_size", "1.5");
  EXPECT_EQ(std::get<double>(net.requireModule(id).params.at("voxel_size")), 1.5);
  EXPECT_THROW_MSG(net.setParameterText(id, "voxel_size", "abc"), InputError, "m1", "voxel_size",
                   "not a number");
  EXPECT_THROW_MSG(net.setParameterText(id, "voxel_size", "-1"), InputError, "out of range");
  EXPECT_THROW_MSG(net.setParameterText(id, "kind", "cube"), InputError, "'cube'", "two_spheres");
  EXPECT_THROW_MSG(net.setParameterText(id, "colour", "red"), InputError, "unknown parameter 'colour'",
                   "voxel_size");
  EXPECT_THROW_MSG(net.setParameter(id, "dims", ParamValue(2.5)), InputError, "whole number");
}

TEST_F(NetworkFixture, ConnectionRules) {
  Network net(reg);
  const auto a = net.addModule("Number"), b = net.addModule("Number"), c = net.addModule("Number");
  const auto v = net.addModule("NeedsVolume"), p = net.addModule("CreatePhantom");
  EXPECT_EQ(net.connect(a, 0, b, 0), "c1");
  EXPECT_THROW_MSG(net.connect(c, 0, b, 0), InputError, "already has a wire", "c1");
  EXPECT_THROW_MSG(net.connect(a, 0, v, 0), InputError, "type mismatch", "Report", "LabelVolume");
  EXPECT_THROW_MSG(net.connect(a, 1, b, 1), InputError, "no output port 1");
  EXPECT_THROW_MSG(net.connect(a, 0, b, 5), InputError, "no input port 5");
  EXPECT_THROW_MSG(net.connect(a, 0, a, 1), InputError, "itself");
  net.connect(b, 0, c, 0);
  EXPECT_THROW_MSG(net.connect(c, 0, a, 0), InputError, "cycle", "m1 -> m2 -> m3 -> m1");
  EXPECT_EQ(net.checkConnection(p, 0, v, 0), "");
  EXPECT_EQ(net.connections().size(), 2u);
}

TEST_F(NetworkFixture, RemoveModuleRemovesItsWiresAndNotifies) {
  Network net(reg);
  std::vector<NetworkEvent::Kind> events;
  const int token = net.subscribe([&](const NetworkEvent& e) { events.push_back(e.kind); });
  const auto a = net.addModule("Number"), b = net.addModule("Number");
  net.connect(a, 0, b, 0);
  net.setParameterText(a, "value", "3");
  net.setParameterText(a, "value", "3"); // unchanged: no event
  net.setPosition(a, 10, 20);
  net.removeModule(b);
  EXPECT_TRUE(net.connections().empty());
  using K = NetworkEvent::Kind;
  EXPECT_EQ(events, (std::vector<K>{K::ModuleAdded, K::ModuleAdded, K::Connected, K::ParameterChanged,
                                    K::PositionChanged, K::Disconnected, K::ModuleRemoved}));
  net.unsubscribe(token);
  net.addModule("Number");
  EXPECT_EQ(events.size(), 7u);
}

// Random DAGs (fixed seeds), with modules removed on the way: the order is the one of a plain
// O(n^2) Kahn that always takes the earliest-inserted ready module, and lookups by id still work
// after removals (the id index is rebuilt).
static std::string moduleId(int k) {
  std::string s = "m"; // (not "m" + std::to_string(k): GCC 12's -Wrestrict false positive)
  s += std::to_string(k);
  return s;
}

TEST_F(NetworkFixture, TopologicalOrderOfRandomNetworksTakesTheEarliestReadyModule) {
  std::mt19937 rng(5);
  for (int round = 0; round < 20; ++round) {
    Network net(reg);
    const int n = 5 + int(rng() % 40);
    for (int i = 0; i < n; ++i) net.addModule("Number");
    for (int e = 0; e < 2 * n; ++e) {
      const std::string a = moduleId(1 + int(rng() % n)), b = moduleId(1 + int(rng() % n));
      const int port = int(rng() % 2);
      if (a != b && net.checkConnection(a, 0, b, port).empty()) net.connect(a, 0, b, port);
    }
    net.removeModule(moduleId(1 + int(rng() % n)));
    std::vector<std::string> expect;
    std::set<std::string> done;
    while (expect.size() < net.modules().size()) {
      for (const auto& m : net.modules()) {
        if (done.count(m.id)) continue;
        bool ready = true;
        for (const auto& c : net.connections()) ready = ready && !(c.to == m.id && !done.count(c.from));
        if (!ready) continue;
        expect.push_back(m.id);
        done.insert(m.id);
        break;
      }
    }
    EXPECT_EQ(net.topologicalOrder(), expect) << "round " << round;
    for (const auto& m : net.modules()) EXPECT_EQ(net.module(m.id), &m);
  }
}

TEST_F(NetworkFixture, TopologicalOrderAndClosures) {
  Network net(reg);
  // m1 -> m3 -> m4, m2 -> m3, m5 alone; inserted out of order.
  for (int i = 0; i < 5; ++i) net.addModule("Number");
  net.connect("m3", 0, "m4", 0);
  net.connect("m1", 0, "m3", 0);
  net.connect("m2", 0, "m3", 1);
  const auto order = net.topologicalOrder();
  auto pos = [&](const std::string& id) { return std::find(order.begin(), order.end(), id) - order.begin(); };
  EXPECT_LT(pos("m1"), pos("m3"));
  EXPECT_LT(pos("m2"), pos("m3"));
  EXPECT_LT(pos("m3"), pos("m4"));
  EXPECT_EQ(order.size(), 5u);
  EXPECT_EQ(net.downstreamClosure({"m2"}), (std::vector<std::string>{"m2", "m3", "m4"}));
  EXPECT_EQ(net.upstream("m3"), (std::vector<std::string>{"m1", "m2"}));
}
