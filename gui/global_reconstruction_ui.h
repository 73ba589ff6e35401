// "Reconstruction > Global reconstruction" in COLMAP 3.8's main window: the
// menu and toolbar actions, the options dialog, the run in a background
// thread with its progress, pause and cancel in the status bar, its log lines
// in the Log dock, and the per-project options file. It is installed into an
// existing MainWindow (src/exe/gui.cc calls InstallGlobalReconstruction), so
// COLMAP's GUI code changes only by one friend declaration (patches 0002 and
// 0003).
#pragma once

#include <glog/logging.h>

#include <QtCore>
#include <QtWidgets>
#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "base/reconstruction_manager.h"
#include "glomap/controllers/global_mapper.h"
#include "glomap/controllers/global_mapper_controller.h"
#include "glomap/util/status.h"

namespace colmap {

class MainWindow;
class GlobalMapperOptionsDialog;
class OptionManager;

class GlobalReconstructionUi : public QObject {
 public:
  // Adds the actions to `main_window`, which owns the result.
  explicit GlobalReconstructionUi(MainWindow* main_window);
  ~GlobalReconstructionUi() override;

  // "Global reconstruction" and "Global reconstruction options...".
  QAction* RunAction() const { return action_run_; }
  QAction* OptionsAction() const { return action_options_; }
  GlobalMapperOptionsDialog* OptionsDialog() const { return options_dialog_; }

  glomap::GlobalMapperOptions* Options() { return &options_; }
  bool IsRunning() const { return controller_ != nullptr && running_; }
  // Paused by the user (the worker may still be on its way to the next
  // check between steps).
  bool IsPaused() const { return IsRunning() && paused_; }
  // Outcome of the last finished run.
  const glomap::Status& LastStatus() const { return last_status_; }
  // How often the viewer has shown an intermediate or final model.
  int NumModelUpdatesShown() const { return num_model_updates_shown_; }
  // The main window's models (what its reconstruction manager holds).
  const ReconstructionManager& Models() const;

  // Automatic reconstruction's "Mapper" choice: Incremental (COLMAP 3.8's
  // run, unchanged) or Global (3.8's extraction and matching, then the
  // global mapper with its progress, pause and cancel in the status bar, the
  // models written to WORKSPACE/sparse).
  QComboBox* AutomaticMapperChoice() const { return automatic_mapper_cb_; }
  // A global Automatic reconstruction is extracting or matching.
  bool IsExtractingAndMatching() const { return extracting_and_matching_; }

  // The options file kept beside a project file: `dir/name.ini` ->
  // `dir/name.global_mapper.ini`. Stock COLMAP 3.8 rejects unknown keys in a
  // project file, so the GlobalMapper.* options never go into it.
  static std::string OptionsFilePath(const std::string& project_path);

 protected:
  // Stops a running reconstruction when the main window closes, before the
  // window's models go away.
  bool eventFilter(QObject* watched, QEvent* event) override;

 private:
  void CreateActions();
  void CreateStatusWidgets();
  void ConnectProjectActions();

  void Run();
  // Runs the global mapper on a database; `ask_overwrite`: ask before
  // replacing the window's models (Global reconstruction) or not
  // (Automatic reconstruction, as the stock widget).
  void StartRun(const std::string& database_path, const std::string& image_path,
                bool ask_overwrite);
  void InstallAutomaticMapperChoice();
  // Automatic reconstruction with the Global mapper: extraction and matching
  // in the widget's progress dialog, then StartRun on the workspace.
  void RunAutomatic();
  void OnExtractionAndMatchingFinished(const std::string& error, bool stopped);
  void Cancel();
  // The status bar's "Pause"/"Resume" button.
  void TogglePause();
  void SetPaused(bool paused);
  void ShowOptions();

  // On the GUI thread while the worker waits: the model is consistent.
  void OnModelUpdated();
  // On the GUI thread once the worker is done.
  void OnFinished();
  void UpdateProgress();
  // Cancels a run and waits for its thread, serving the worker's pending
  // render requests meanwhile (it may be blocked on one).
  void StopAndWait();

  // Disables every action that could touch the models during a run, and
  // restores the previous states afterwards.
  void LockWindow();
  void UnlockWindow();

  void LoadProjectOptions();
  void SaveProjectOptions();
  void ShowError(const std::string& message);
  // Qt does not let an exception leave a slot or an event handler (it
  // terminates the GUI): every entry point from Qt runs its body through
  // this, which shows the exception (std::bad_alloc above all) as an error
  // with the command line's text instead.
  void ReportExceptions(const std::function<void()>& body);

  MainWindow* window_;
  glomap::GlobalMapperOptions options_;
  std::unique_ptr<glomap::GlobalMapperController> controller_;
  bool running_ = false;
  bool paused_ = false;
  bool cancelling_ = false;
  bool closing_ = false;
  glomap::Status last_status_;
  int num_model_updates_shown_ = 0;
  // Project file whose options file was last read or written.
  std::string options_project_path_;

  QAction* action_run_ = nullptr;
  QAction* action_options_ = nullptr;
  GlobalMapperOptionsDialog* options_dialog_ = nullptr;

  QLabel* progress_label_ = nullptr;
  QProgressBar* progress_bar_ = nullptr;
  QPushButton* pause_button_ = nullptr;
  QPushButton* cancel_button_ = nullptr;
  QTimer* progress_timer_ = nullptr;
  // Copies glog's lines into the Log dock (installed for our lifetime).
  std::unique_ptr<google::LogSink> log_sink_;

  std::vector<std::pair<QAction*, bool>> locked_actions_;

  QComboBox* automatic_mapper_cb_ = nullptr;
  bool extracting_and_matching_ = false;
  // The extraction and matching thread while it runs (owned by the
  // Automatic reconstruction widget's thread control).
  Thread* extraction_and_matching_thread_ = nullptr;
  // The global Automatic reconstruction's options (extraction, matching,
  // the models' project.ini) and where its models go; empty for Global
  // reconstruction.
  std::unique_ptr<OptionManager> automatic_options_;
  std::string automatic_sparse_path_;
  bool automatic_sparse_ = true;
  bool automatic_dense_ = false;
};

// Adds "Global reconstruction" to `main_window` (call once, right after
// constructing it); the main window owns the returned object.
GlobalReconstructionUi* InstallGlobalReconstruction(MainWindow* main_window);

}  // namespace colmap
