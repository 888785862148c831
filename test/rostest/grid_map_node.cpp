// The map rbpf_slam_node serves as a grid (grid_map.test, landmark_map.test): ~map and
// ~map_metadata arrive latched with the configured resolution and hold occupied and free
// cells, the metadata matches the map, and ~dynamic_map (nav_msgs/GetMap) returns the same
// kind of map. Parameters: ~resolution (expected), ~min_occupied, ~min_free.

#include <gtest/gtest.h>
#include <nav_msgs/GetMap.h>
#include <nav_msgs/MapMetaData.h>
#include <nav_msgs/OccupancyGrid.h>
#include <ros/ros.h>

#include <algorithm>
#include <cmath>
#include <mutex>

namespace rbpf_slam {
namespace {

long countIn(const nav_msgs::OccupancyGrid& map, int lo, int hi) {
  return std::count_if(map.data.begin(), map.data.end(),
                       [&](int8_t v) { return v >= lo && v <= hi; });
}

TEST(GridMap, MapMetadataAndDynamicMapServeTheGrid) {
  ros::NodeHandle nh, pnh("~");
  double resolution = 0.0;
  int min_occupied = 1, min_free = 1;
  pnh.getParam("resolution", resolution);
  pnh.getParam("min_occupied", min_occupied);
  pnh.getParam("min_free", min_free);
  std::mutex mutex;
  nav_msgs::OccupancyGrid last_map;
  nav_msgs::MapMetaData last_metadata;
  int maps = 0, metadata = 0;
  ros::Subscriber map_sub = nh.subscribe<nav_msgs::OccupancyGrid>(
      "/rbpf_slam_node/map", 1, [&](const nav_msgs::OccupancyGrid::ConstPtr& m) {
        std::lock_guard<std::mutex> lock(mutex);
        last_map = *m;
        ++maps;
      });
  ros::Subscriber metadata_sub = nh.subscribe<nav_msgs::MapMetaData>(
      "/rbpf_slam_node/map_metadata", 1, [&](const nav_msgs::MapMetaData::ConstPtr& m) {
        std::lock_guard<std::mutex> lock(mutex);
        last_metadata = *m;
        ++metadata;
      });
  ros::AsyncSpinner spinner(1);
  spinner.start();
  // Wait for a map with enough occupied cells (the robot has to see the walls first).
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(150.0);
  bool enough = false;
  while (ros::WallTime::now() < deadline && !enough) {
    {
      std::lock_guard<std::mutex> lock(mutex);
      enough = maps > 0 && countIn(last_map, 65, 100) >= min_occupied &&
               countIn(last_map, 0, 19) >= min_free;
    }
    ros::WallDuration(0.2).sleep();
  }
  std::lock_guard<std::mutex> lock(mutex);
  ASSERT_GT(maps, 0) << "nothing on ~map";
  EXPECT_TRUE(enough) << "occupied " << countIn(last_map, 65, 100) << ", free "
                      << countIn(last_map, 0, 19);
  EXPECT_NEAR(last_map.info.resolution, resolution, 1e-6);
  EXPECT_EQ(last_map.header.frame_id, "map");
  EXPECT_EQ(last_map.data.size(), static_cast<size_t>(last_map.info.width) * last_map.info.height);
  ASSERT_GT(metadata, 0) << "nothing on ~map_metadata";
  EXPECT_NEAR(last_metadata.resolution, resolution, 1e-6);
  EXPECT_GT(last_metadata.width, 0u);

  nav_msgs::GetMap get_map;
  ASSERT_TRUE(ros::service::waitForService("/rbpf_slam_node/dynamic_map", ros::Duration(10.0)));
  ASSERT_TRUE(ros::service::call("/rbpf_slam_node/dynamic_map", get_map));
  EXPECT_NEAR(get_map.response.map.info.resolution, resolution, 1e-6);
  EXPECT_EQ(get_map.response.map.data.size(),
            static_cast<size_t>(get_map.response.map.info.width) *
                get_map.response.map.info.height);
  EXPECT_GE(countIn(get_map.response.map, 65, 100), min_occupied);
}

}  // namespace
}  // namespace rbpf_slam

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "grid_map_test");
  return RUN_ALL_TESTS();
}
