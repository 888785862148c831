// Configuration errors in ROS parameters (see bad_config.test): the parameter tree goes
// through the same loader as YAML files, and rbpf_slam_node exits with the key named.

#include <gtest/gtest.h>
#include <poll.h>
#include <ros/ros.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "rbpf_slam/ros/param_loader.h"
#include "rbpf_slam/ros/sim_node.h"

namespace rbpf_slam {
namespace {

struct RunResult {
  bool exited = false;  // false: still running at the deadline (then stopped with SIGINT)
  int exit_code = -1;
  bool signalled = false;
  std::string output;  // stdout and stderr
};

/// Runs argv with stdout and stderr captured, for at most timeout_s seconds.
RunResult run(const std::vector<std::string>& args, double timeout_s) {
  RunResult result;
  int fds[2];
  if (pipe(fds) != 0) return result;
  const pid_t pid = fork();
  if (pid == 0) {
    dup2(fds[1], STDOUT_FILENO);
    dup2(fds[1], STDERR_FILENO);
    close(fds[0]);
    close(fds[1]);
    std::vector<char*> argv;
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    execv(argv[0], argv.data());
    _exit(127);
  }
  close(fds[1]);
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(timeout_s);
  int status = 0;
  char buffer[4096];
  bool open = true;
  while (open && ros::WallTime::now() < deadline) {
    pollfd p{fds[0], POLLIN, 0};
    if (poll(&p, 1, 100) > 0) {
      const ssize_t n = read(fds[0], buffer, sizeof(buffer));
      if (n > 0) {
        result.output.append(buffer, n);
      } else {
        open = false;  // the child closed its output: it has exited
      }
    }
  }
  if (open) {  // still running at the deadline
    kill(pid, SIGINT);
    waitpid(pid, &status, 0);
  } else {
    waitpid(pid, &status, 0);
    result.exited = true;
  }
  while (true) {  // whatever is left in the pipe
    const ssize_t n = read(fds[0], buffer, sizeof(buffer));
    if (n <= 0) break;
    result.output.append(buffer, n);
  }
  close(fds[0]);
  if (WIFEXITED(status)) result.exit_code = WEXITSTATUS(status);
  result.signalled = WIFSIGNALED(status);
  return result;
}

/// rbpf_slam_node sits next to this executable in the devel space.
std::string slamNodePath() {
  char self[4096] = {0};
  const ssize_t n = readlink("/proc/self/exe", self, sizeof(self) - 1);
  std::string path(self, n > 0 ? n : 0);
  return path.substr(0, path.rfind('/') + 1) + "rbpf_slam_node";
}

/// Starts rbpf_slam_node as `name` after adding `params` (key, value) to its namespace, where
/// bad_config.test loaded the laser config.
RunResult runNodeWith(const std::string& name,
                      const std::vector<std::pair<std::string, XmlRpc::XmlRpcValue>>& params,
                      double timeout_s) {
  EXPECT_TRUE(ros::param::has("/" + name + "/variant")) << "bad_config.test loads the config";
  for (const auto& [key, value] : params) ros::param::set("/" + name + "/" + key, value);
  return run({slamNodePath(), "__name:=" + name}, timeout_s);
}

TEST(ParamsToYaml, ConvertsScalarsListsAndNamespaces) {
  XmlRpc::XmlRpcValue tree;
  tree["particles"] = 30;
  tree["resample_threshold"] = 0.25;
  tree["use_lines"] = false;
  tree["variant"] = std::string("fastslam2");
  tree["motion"]["alpha1"] = 0.1;
  tree["list"][0] = 1.5;
  tree["list"][1] = 2;
  const YAML::Node yaml = rosbridge::paramsToYaml(tree);
  ASSERT_TRUE(yaml.IsMap());
  EXPECT_EQ(yaml["particles"].as<int>(), 30);
  EXPECT_DOUBLE_EQ(yaml["resample_threshold"].as<double>(), 0.25);
  EXPECT_FALSE(yaml["use_lines"].as<bool>());
  EXPECT_EQ(yaml["variant"].as<std::string>(), "fastslam2");
  EXPECT_DOUBLE_EQ(yaml["motion"]["alpha1"].as<double>(), 0.1);
  ASSERT_TRUE(yaml["list"].IsSequence());
  EXPECT_DOUBLE_EQ(yaml["list"][0].as<double>(), 1.5);
  EXPECT_EQ(yaml["list"][1].as<int>(), 2);
}

TEST(ParamsToYaml, DoublesSurviveExactly) {
  const double value = 0.1 + 0.2;  // not representable in few digits
  EXPECT_EQ(rosbridge::paramsToYaml(XmlRpc::XmlRpcValue(value)).as<double>(), value);
  EXPECT_TRUE(std::isinf(rosbridge::paramsToYaml(XmlRpc::XmlRpcValue(HUGE_VAL)).as<double>()));
}

// A partial tree (as with `rosrun rbpf_slam rbpf_slam_node _particles:=17`): every key and
// every section is optional.
TEST(LoadConfigFromParams, SameRulesAsYamlFiles) {
  ros::NodeHandle nh("~loader");
  nh.deleteParam("");
  nh.setParam("particles", 17);
  nh.setParam("motion/alpha1", 0.05);
  const io::SlamConfig config = rosbridge::loadConfigFromParams(nh);
  EXPECT_EQ(config.filter.particles, 17);
  EXPECT_DOUBLE_EQ(config.filter.motion.alpha1, 0.05);

  nh.setParam("motion/alpah2", 0.05);
  try {
    rosbridge::loadConfigFromParams(nh);
    ADD_FAILURE() << "an unknown key was accepted";
  } catch (const io::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("alpah2"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("~ parameters"), std::string::npos) << e.what();
  }
  nh.deleteParam("motion/alpah2");
  nh.setParam("resample_threshold", std::nan(""));
  EXPECT_THROW(rosbridge::loadConfigFromParams(nh), io::ConfigError);
  nh.deleteParam("");
}

// With ~config_file and ~config_text (the launch files set them beside the rosparam load):
// a key written twice in the file (rosparam keeps one copy without a word) is refused naming
// the file and the key, and a bad parameter names the file it came from. The text is what
// roslaunch read, so no path is opened here (a relative one would not be found from the
// node's working directory).
TEST(LoadConfigFromParams, TheConfigFileIsCheckedAndNamed) {
  const std::string file = "my_configs/twice.yaml";  // relative, as roslaunch may be given
  ros::NodeHandle nh("~file_loader");
  nh.deleteParam("");
  nh.setParam("particles", 40);  // what rosparam loaded from it
  nh.setParam("config_file", file);
  nh.setParam("config_text", std::string("particles: 30\nmotion:\n  alpha1: 0.1\n"
                                         "  alpha1: 0.2\nparticles: 40\n"));
  try {
    rosbridge::loadConfigFromParams(nh);
    ADD_FAILURE() << "a key written twice in the config file was accepted";
  } catch (const io::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find(file + ": key 'alpha1' appears more than once in motion"),
              std::string::npos)
        << e.what();
  }
  nh.setParam("config_text", std::string("particles: 40\nmotion: {alpha1: 0.1}\n"));
  EXPECT_EQ(rosbridge::loadConfigFromParams(nh).filter.particles, 40);  // neither is a key
  nh.setParam("particles", -3);  // e.g. set after the file by another <param>
  try {
    rosbridge::loadConfigFromParams(nh);
    ADD_FAILURE() << "particles -3 was accepted";
  } catch (const io::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("loaded from " + file), std::string::npos) << e.what();
  }
  nh.setParam("particles", 40);
  // rosparam's YAML 1.1 reads 040 as octal 32 (the parameter the node sees); offline_slam
  // refuses it, so the node must too, from the file's text.
  for (const char* written : {"040", "0x28", "-012", "09"}) {
    nh.setParam("config_text", "seed: 1\nresampling:\n  threshold: 0.5\nparticles: " +
                                   std::string(written) + "\n");
    try {
      rosbridge::loadConfigFromParams(nh);
      ADD_FAILURE() << "particles: " << written << " in the file was accepted";
    } catch (const io::ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find(file + ": particles = " + written +
                                           " is not a decimal integer"),
                std::string::npos)
          << e.what();
    }
  }
  nh.setParam("config_text", std::string("particles: 40\nname: '040'\nsigma: 0.05\n"));
  EXPECT_EQ(rosbridge::loadConfigFromParams(nh).filter.particles, 40);  // quoted, and decimals
  nh.setParam("config_text", std::string("particles: [1, 2\n"));
  EXPECT_THROW(rosbridge::loadConfigFromParams(nh), io::ConfigError);
  nh.setParam("config_text", std::string("particles: 40\n"));
  nh.setParam("config_file", 3);
  EXPECT_THROW(rosbridge::loadConfigFromParams(nh), io::ConfigError);
  nh.deleteParam("");
}

// sim_node's parameters: a mistyped name or a value of the wrong type used to fall back to
// the default without a word (`_rate:=fast` ran at 1x, `_seeed:=3` with seed 0).
TEST(SimNodeParameters, MistypedNamesAndValuesAreRefused) {
  ros::NodeHandle nh("~sim");
  nh.deleteParam("");
  nh.setParam("world", std::string("worlds/test_small.yaml"));
  nh.setParam("seed", 3);
  nh.setParam("rate", 2);  // an integer is a number
  nh.setParam("publish_clock", true);
  const rosbridge::SimNodeOptions ok = rosbridge::loadSimNodeOptions(nh);
  EXPECT_EQ(ok.seed, 3);
  EXPECT_DOUBLE_EQ(ok.rate, 2.0);
  auto errorWith = [&nh](const std::string& key, const XmlRpc::XmlRpcValue& value) {
    XmlRpc::XmlRpcValue copy = value;
    nh.setParam(key, copy);
    std::string message;
    try {
      rosbridge::loadSimNodeOptions(nh);
    } catch (const std::invalid_argument& e) {
      message = e.what();
    }
    nh.deleteParam(key);
    return message;
  };
  EXPECT_NE(
      errorWith("seeed", XmlRpc::XmlRpcValue(3)).find("sim/seeed is not a sim_node parameter"),
      std::string::npos);
  nh.setParam("rate", 2);
  EXPECT_NE(errorWith("rate", XmlRpc::XmlRpcValue("fast")).find("sim/rate must be a number"),
            std::string::npos);
  EXPECT_NE(errorWith("seed", XmlRpc::XmlRpcValue(2.5)).find("sim/seed must be an integer"),
            std::string::npos);
  // roslaunch gives rate:=1e3 as the text "1e3": still a number.
  nh.setParam("rate", std::string("1e3"));
  EXPECT_DOUBLE_EQ(rosbridge::loadSimNodeOptions(nh).rate, 1000.0);
  nh.deleteParam("");
}

TEST(SlamNode, UnknownKeyStopsTheNodeNamingTheKey) {
  const RunResult r = runNodeWith("bad_config_slam", {{"partciles", 10}}, 30.0);
  ASSERT_TRUE(r.exited) << "the node kept running with an unknown key:\n" << r.output;
  EXPECT_FALSE(r.signalled) << r.output;
  EXPECT_NE(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("partciles"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("unknown key"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("terminate called"), std::string::npos) << r.output;
}

TEST(SlamNode, OutOfRangeValueStopsTheNodeNamingKeyAndRange) {
  const RunResult r = runNodeWith("bad_range_slam", {{"particles", 0}}, 30.0);
  ASSERT_TRUE(r.exited) << "the node kept running with particles = 0:\n" << r.output;
  EXPECT_NE(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("particles = 0"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("out of range"), std::string::npos) << r.output;
}

TEST(SlamNode, ValidParametersKeepTheNodeRunning) {
  // The control case: the same launch with a correct tree must not exit.
  const RunResult r = runNodeWith("good_config_slam", {{"particles", 10}}, 5.0);
  EXPECT_NE(r.output.find("10 particles"), std::string::npos) << r.output;
  EXPECT_FALSE(r.exited) << "exit code " << r.exit_code << ":\n" << r.output;
}

}  // namespace
}  // namespace rbpf_slam

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "bad_config_check");
  ros::NodeHandle nh;  // keeps the node's connection to the master for param calls
  return RUN_ALL_TESTS();
}
