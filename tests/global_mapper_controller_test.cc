// The thread that `colmap global_mapper` and the GUI run: whatever the
// pipeline throws ends the run as its error, and never leaves the thread
// (which would terminate the command and the GUI).
#include "glomap/controllers/global_mapper_controller.h"

#include <gtest/gtest.h>

#include <new>
#include <stdexcept>
#include <string>
#include <system_error>

#include "tests/support/synthetic_scene.h"
#include "tests/support/test_paths.h"

namespace glomap {
namespace {

// Runs the controller on `database_path`; when the stage `throw_at` begins,
// `throw_exception` throws from the worker thread, inside the pipeline.
Status RunThrowingAt(const std::string& database_path,
                     const std::string& throw_at,
                     const std::function<void()>& throw_exception,
                     colmap::ReconstructionManager* manager) {
  GlobalMapperOptions options;
  options.num_threads = 1;
  GlobalMapperController controller(options, database_path, manager);
  bool finished = false;
  controller.AddCallback(GlobalMapperController::STAGE_CALLBACK, [&]() {
    if (controller.StageName() == throw_at) throw_exception();
  });
  controller.AddCallback(GlobalMapperController::FINISHED_CALLBACK,
                         [&]() { finished = true; });
  controller.Start();
  controller.Wait();
  EXPECT_TRUE(finished);
  return controller.RunStatus();
}

TEST(GlobalMapperController, ExceptionsEndTheRunAsItsError) {
  const std::string dir = testing::CreateTestDir("controller_exceptions");
  const std::string database_path = dir + "/database.db";
  SyntheticSceneOptions scene;
  scene.num_images = 10;
  colmap::Reconstruction ground_truth;
  ASSERT_TRUE(WriteSyntheticScene(scene, database_path, &ground_truth).ok());

  const struct {
    std::string stage;
    std::function<void()> throw_exception;
    std::string message;
  } cases[] = {
      {"Global positioning", []() { throw std::bad_alloc(); },
       "Out of memory: the run needs more memory than this machine (or its "
       "memory limit) allows."},
      {"Rotation averaging",
       []() { throw std::out_of_range("unordered_map::at"); },
       "Internal error: unordered_map::at (an unexpected exception; please "
       "report it)."},
      {"Bundle adjustment",
       []() {
         throw std::system_error(
             std::make_error_code(std::errc::resource_unavailable_try_again),
             "thread");
       },
       "Out of resources: the system refused a new thread"},
      {"Tracks", []() { throw std::runtime_error("two\nlines"); },
       "Internal error: two lines"},
      {"Database", []() { throw 42; },
       "Internal error: an unexpected exception of unknown type"},
  };
  for (const auto& c : cases) {
    colmap::ReconstructionManager manager;
    const Status status =
        RunThrowingAt(database_path, c.stage, c.throw_exception, &manager);
    EXPECT_FALSE(status.ok()) << c.stage;
    EXPECT_FALSE(status.cancelled()) << c.stage;
    EXPECT_EQ(status.message().rfind(c.message, 0), 0u)
        << c.stage << ": " << status.message();
    // The working model is gone, as after any failed run.
    EXPECT_EQ(manager.Size(), 0u) << c.stage;
  }

  colmap::ReconstructionManager manager;
  const Status status = RunThrowingAt(
      database_path, "no such stage", []() {}, &manager);
  ASSERT_TRUE(status.ok()) << status.message();
  ASSERT_EQ(manager.Size(), 1u);
  EXPECT_EQ(manager.Get(0).NumRegImages(), 10u);
}

}  // namespace
}  // namespace glomap
