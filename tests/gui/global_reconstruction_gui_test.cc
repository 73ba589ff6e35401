// "Reconstruction > Global reconstruction" in a real COLMAP MainWindow, as a
// user drives it: open a project (`colmap gui --project_path ...`), click the
// menu entry, wait, look at the models, the statistics window, File > Export,
// the Log dock and the clock, pause, resume, cancel, and take a screenshot.
// Runs under Xvfb with Mesa (see gui/CMakeLists.txt); the cases on
// fountain-P11 skip when the shared datasets are absent, the cancel and pause
// cases run on synthetic projects.
#include <gtest/gtest.h>

#include <QtWidgets>
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <memory>
#include <string>
#include <thread>
#include <type_traits>
#include <variant>
#include <vector>

#include "base/database.h"
#include "colmap_ext/global_mapper_options.h"
#include "colmap_ext/terminate_handler.h"
#include "gui/global_mapper_options_dialog.h"
#include "gui/global_reconstruction_ui.h"
#include "tests/support/synthetic_scene.h"
#include "tests/support/test_paths.h"
#include "ui/main_window.h"
#include "util/option_manager.h"

namespace colmap {
namespace {

namespace fs = std::filesystem;

constexpr qint64 kRunTimeoutMs = 10 * 60 * 1000;

std::string FountainDir() {
  const std::string datasets = glomap::testing::SharedDatasetsDir();
  if (datasets.empty()) return "";
  const fs::path dir = fs::path(datasets) / "fountain-P11";
  if (!fs::exists(dir / "database.db") || !fs::is_directory(dir / "images")) {
    return "";
  }
  return dir.string();
}

// Finds an action by its text in one of the window's menus.
QAction* FindMenuAction(QMainWindow* window, const QString& menu_title,
                        const QString& text) {
  for (QAction* menu_action : window->menuBar()->actions()) {
    if (menu_action->menu() == nullptr || menu_action->text() != menu_title) {
      continue;
    }
    for (QAction* action : menu_action->menu()->actions()) {
      if (action->text() == text) return action;
    }
  }
  return nullptr;
}

void ProcessEventsFor(int msecs) {
  QElapsedTimer timer;
  timer.start();
  while (timer.elapsed() < msecs) {
    QApplication::processEvents(QEventLoop::AllEvents, 20);
  }
}

// Spins the event loop until `done` or the timeout; returns `done()`.
bool WaitUntil(const std::function<bool()>& done, qint64 timeout_ms) {
  QElapsedTimer timer;
  timer.start();
  while (!done() && timer.elapsed() < timeout_ms) {
    QApplication::processEvents(QEventLoop::AllEvents, 20);
  }
  return done();
}

// Answers modal dialogs (message boxes, file dialogs) as they appear, from
// inside their own event loop, like a user would.
class ModalDialogHandler {
 public:
  explicit ModalDialogHandler(std::function<bool(QWidget*)> handle)
      : handle_(std::move(handle)) {
    QObject::connect(&timer_, &QTimer::timeout, [this]() {
      QWidget* modal = QApplication::activeModalWidget();
      if (modal != nullptr && modal->isVisible() && handle_(modal)) {
        ++num_handled_;
      }
    });
    timer_.start(50);
  }

  int NumHandled() const { return num_handled_; }

 private:
  std::function<bool(QWidget*)> handle_;
  QTimer timer_;
  int num_handled_ = 0;
};

// The visible status bar labels, one per line.
QString StatusBarText(QMainWindow* window) {
  QString text;
  for (QLabel* label : window->statusBar()->findChildren<QLabel*>()) {
    if (label->isVisible()) text += label->text() + "\n";
  }
  return text;
}

// The status bar label whose text starts with `prefix`, or "".
QString StatusBarLabel(QMainWindow* window, const QString& prefix) {
  for (QLabel* label : window->statusBar()->findChildren<QLabel*>()) {
    if (label->isVisible() && label->text().startsWith(prefix)) {
      return label->text();
    }
  }
  return "";
}

// A ModalDialogHandler callback for message boxes: records each box's text
// in `texts` and answers it (Yes where the box has it, when `answer_yes`;
// otherwise accept or reject, as `accept` says).
std::function<bool(QWidget*)> RecordMessageBoxes(QStringList* texts,
                                                 bool answer_yes,
                                                 bool accept = false) {
  return [texts, answer_yes, accept](QWidget* modal) {
    QMessageBox* box = qobject_cast<QMessageBox*>(modal);
    if (box == nullptr) return false;
    *texts << box->text();
    if (answer_yes && box->button(QMessageBox::Yes) != nullptr) {
      box->button(QMessageBox::Yes)->click();
    } else if (accept) {
      box->accept();
    } else {
      box->reject();
    }
    return true;
  };
}

// The visible status bar button labelled `text`, or null.
QPushButton* StatusBarButton(QMainWindow* window, const QString& text) {
  for (QPushButton* button :
       window->statusBar()->findChildren<QPushButton*>()) {
    if (button->text() == text && button->isVisible()) return button;
  }
  return nullptr;
}

// What the Log dock shows (COLMAP's LogWidget: a QPlainTextEdit in the dock
// titled "Log").
QString LogDockText(QMainWindow* window) {
  for (QDockWidget* dock : window->findChildren<QDockWidget*>()) {
    if (dock->windowTitle() != "Log") continue;
    if (QPlainTextEdit* text = dock->findChild<QPlainTextEdit*>()) {
      return text->toPlainText();
    }
  }
  return "";
}

// Text of the statistics window's row `name`, or "" if absent.
QString StatisticsValue(QMainWindow* window, const QString& name) {
  for (QTableWidget* table : window->findChildren<QTableWidget*>()) {
    for (int row = 0; row < table->rowCount(); ++row) {
      if (table->item(row, 0) != nullptr &&
          table->item(row, 0)->text() == name && table->item(row, 1)) {
        return table->item(row, 1)->text();
      }
    }
  }
  return "";
}

// Fraction of pixels in `rect` that differ from its corner colour.
double DrawnFraction(const QImage& image, const QRect& rect) {
  const QRgb background = image.pixel(rect.topLeft() + QPoint(2, 2));
  size_t num_drawn = 0;
  size_t num_pixels = 0;
  for (int y = rect.top(); y <= rect.bottom(); y += 2) {
    for (int x = rect.left(); x <= rect.right(); x += 2) {
      ++num_pixels;
      if (image.pixel(x, y) != background) ++num_drawn;
    }
  }
  return num_pixels == 0 ? 0 : static_cast<double>(num_drawn) / num_pixels;
}

// Each case opens its project in a MainWindow of its own, as
// `colmap gui --project_path <project>` does (src/exe/gui.cc), with the
// global reconstruction installed.
class GlobalReconstructionGui : public ::testing::Test {
 protected:
  // A project as the user has it on disk, in the new test folder `name`: a
  // copy of fountain-P11's database (never write into the shared folder) and
  // a project.ini written the stock way. False if the dataset is absent.
  bool WriteFountainProject(const std::string& name) {
    const std::string fountain_dir = FountainDir();
    if (fountain_dir.empty()) return false;
    test_dir_ = glomap::testing::CreateTestDir(name);
    const fs::path database_path = fs::path(test_dir_) / "database.db";
    fs::copy_file(fs::path(fountain_dir) / "database.db", database_path,
                  fs::copy_options::overwrite_existing);
    fs::permissions(database_path,
                    fs::perms::owner_read | fs::perms::owner_write,
                    fs::perm_options::add);
    WriteProjectFile(database_path, fs::path(fountain_dir) / "images");
    return true;
  }

  // A project on a synthetic scene of `num_images` images (no image files:
  // the pipeline reads only the database) in the new test folder `name`, for
  // runs that must last a few seconds. The pairs are verified against the
  // true geometry: COLMAP's own two-view estimation would take a minute and a
  // half for 100 images here. False (the failure reported) if it could not
  // be written.
  bool WriteSyntheticProject(const std::string& name, int num_images) {
    test_dir_ = glomap::testing::CreateTestDir(name);
    const fs::path database_path = fs::path(test_dir_) / "database.db";
    const fs::path image_path = fs::path(test_dir_) / "images";
    fs::create_directories(image_path);
    glomap::SyntheticSceneOptions scene;
    scene.num_images = num_images;
    scene.random_seed = 5;
    scene.verification = "ground_truth";
    Reconstruction ground_truth;
    const glomap::Status written = glomap::WriteSyntheticScene(
        scene, database_path.string(), &ground_truth);
    EXPECT_TRUE(written.ok()) << written.message();
    WriteProjectFile(database_path, image_path);
    return !HasFailure();
  }

  // The project.ini of the test folder, written the stock way.
  void WriteProjectFile(const fs::path& database_path,
                        const fs::path& image_path) {
    OptionManager project;
    project.AddAllOptions();
    *project.database_path = database_path.string();
    *project.image_path = image_path.string();
    project_path_ = (fs::path(test_dir_) / "project.ini").string();
    project.Write(project_path_);
  }

  // Opens the project with the options of `colmap gui --project_path
  // <project>` and shows the window, at `size` where one is given.
  void OpenProject(const QSize& size = QSize()) {
    options_.AddDefaultOption("import_path", &import_path_);
    options_.AddAllOptions();
    std::vector<std::string> args = {"colmap", "--project_path", project_path_};
    std::vector<char*> argv;
    for (std::string& arg : args) argv.push_back(arg.data());
    options_.Parse(static_cast<int>(argv.size()), argv.data());
    window_ = std::make_unique<MainWindow>(options_);
    ui_ = InstallGlobalReconstruction(window_.get());
    if (size.isValid()) window_->resize(size);
    window_->show();
  }

  // From now on, records every message box in `messages_` and answers it as
  // RecordMessageBoxes says.
  void RecordMessages(bool answer_yes, bool accept = false) {
    message_boxes_ = std::make_unique<ModalDialogHandler>(
        RecordMessageBoxes(&messages_, answer_yes, accept));
  }

  MainWindow* window() { return window_.get(); }

  // Opens Reconstruction > Automatic reconstruction from the menu and fills
  // in its workspace and image folders, with the GPU off (no SiftGPU under
  // Xvfb); the widget, or null (the failure reported) if a part is missing.
  QWidget* OpenAutomaticReconstruction(const fs::path& workspace,
                                       const fs::path& images);

  // Starts a global run from the menu and waits until the status bar shows
  // `stage`; true if the run is still going then (the stage is reached
  // mid-run).
  // The synthetic projects store their true two-view geometries, from which
  // the relative poses of 100 images take a fifth of a second; RANSAC on
  // every pair makes the stage last seconds, long enough to be seen running.
  void RunRansacOnEveryPair() {
    ui_->Options()->relative_pose.use_stored_geometry = false;
  }

  bool RunUntilStage(const QString& stage) {
    ui_->RunAction()->trigger();
    if (!ui_->IsRunning()) return false;
    WaitUntil(
        [&]() {
          return StatusBarText(window()).contains(stage) || !ui_->IsRunning();
        },
        kRunTimeoutMs);
    return ui_->IsRunning();
  }

  // Clicks Cancel during a run: the run stops within a second, cancelled,
  // with no model. `when` names the moment in the printed time.
  void CancelPromptly(const std::string& when) {
    QPushButton* cancel = StatusBarButton(window(), "Cancel");
    ASSERT_NE(cancel, nullptr);
    QElapsedTimer cancel_timer;
    cancel_timer.start();
    cancel->click();
    ASSERT_TRUE(WaitUntil([&]() { return !ui_->IsRunning(); }, 60000));
    printf("Cancel %s took %lld ms\n", when.c_str(), cancel_timer.elapsed());
    EXPECT_LT(cancel_timer.elapsed(), 1000) << "Cancel is not prompt";
    EXPECT_TRUE(ui_->LastStatus().cancelled()) << ui_->LastStatus().message();
    EXPECT_EQ(ui_->Models().Size(), 0u);
    EXPECT_TRUE(StatusBarText(window()).contains("cancelled"))
        << StatusBarText(window()).toStdString();
  }

  // Closes the window during a run (RecordMessages(true) answers "Do you
  // really want to quit?" with Yes, the one message allowed): it closes
  // within `max_ms` and stops the run, leaving no model. `what` names the
  // case in the printed time.
  void CloseStopsTheRun(const std::string& what, qint64 max_ms) {
    QElapsedTimer close_timer;
    close_timer.start();
    EXPECT_TRUE(window_->close());
    printf("%s took %lld ms\n", what.c_str(), close_timer.elapsed());
    EXPECT_LT(close_timer.elapsed(), max_ms);
    EXPECT_FALSE(window_->isVisible());
    ProcessEventsFor(200);
    EXPECT_FALSE(ui_->IsRunning());
    EXPECT_EQ(ui_->Models().Size(), 0u);
    ASSERT_EQ(messages_.size(), 1) << messages_.join("\n").toStdString();
    EXPECT_TRUE(messages_.front().contains("quit"));
  }

  std::string test_dir_;
  std::string project_path_;
  // `import_path_` must outlive `options_`, which keeps a pointer to it.
  std::string import_path_;
  OptionManager options_;
  std::unique_ptr<MainWindow> window_;
  GlobalReconstructionUi* ui_ = nullptr;
  QStringList messages_;
  std::unique_ptr<ModalDialogHandler> message_boxes_;
};

// The field in the row labelled `label` of an options widget's grid (COLMAP's
// OptionsWidget puts the label in column 0, the field in column 1).
QWidget* FieldOfRow(QWidget* widget, const QString& label) {
  QGridLayout* grid = widget->findChild<QGridLayout*>();
  if (grid == nullptr) return nullptr;
  for (int row = 0; row < grid->rowCount(); ++row) {
    QLayoutItem* label_item = grid->itemAtPosition(row, 0);
    QLayoutItem* field_item = grid->itemAtPosition(row, 1);
    if (label_item == nullptr || field_item == nullptr) continue;
    QLabel* row_label = qobject_cast<QLabel*>(label_item->widget());
    if (row_label != nullptr && row_label->text() == label) {
      return field_item->widget();
    }
  }
  return nullptr;
}

QWidget* GlobalReconstructionGui::OpenAutomaticReconstruction(
    const fs::path& workspace, const fs::path& images) {
  QAction* automatic =
      FindMenuAction(window(), "Reconstruction", "Automatic reconstruction");
  if (automatic == nullptr) {
    ADD_FAILURE() << "No Reconstruction > Automatic reconstruction";
    return nullptr;
  }
  automatic->trigger();
  ProcessEventsFor(200);
  QWidget* widget = nullptr;
  for (QWidget* candidate : window()->findChildren<QWidget*>()) {
    if (candidate->isWindow() &&
        candidate->windowTitle() == "Automatic reconstruction") {
      widget = candidate;
    }
  }
  if (widget == nullptr) {
    ADD_FAILURE() << "No Automatic reconstruction window";
    return nullptr;
  }
  QLineEdit* workspace_field =
      qobject_cast<QLineEdit*>(FieldOfRow(widget, "Workspace folder"));
  QLineEdit* image_field =
      qobject_cast<QLineEdit*>(FieldOfRow(widget, "Image folder"));
  QCheckBox* gpu = qobject_cast<QCheckBox*>(FieldOfRow(widget, "GPU"));
  if (workspace_field == nullptr || image_field == nullptr || gpu == nullptr) {
    ADD_FAILURE() << "Automatic reconstruction lacks a folder or GPU field";
    return nullptr;
  }
  workspace_field->setText(QString::fromStdString(workspace.string()));
  image_field->setText(QString::fromStdString(images.string()));
  gpu->setChecked(false);
  return widget;
}

TEST_F(GlobalReconstructionGui, RunsFromTheMenuOnFountain) {
  if (!WriteFountainProject("global_reconstruction_gui")) {
    GTEST_SKIP() << "Shared dataset fountain-P11 not found.";
  }

  // Options beside the project are picked up on start: a non-default seed.
  glomap::GlobalMapperOptions saved_options;
  saved_options.random_seed = 7;
  ASSERT_TRUE(glomap::WriteGlobalMapperOptionsFile(
      GlobalReconstructionUi::OptionsFilePath(project_path_), saved_options));

  OpenProject(QSize(1400, 860));
  EXPECT_EQ(std::get_terminate(), &ReportTerminationAndExit);
  ProcessEventsFor(300);
  EXPECT_EQ(ui_->Options()->random_seed, 7);

  // The menu entry sits after the incremental actions; a tool-bar button too.
  QAction* run =
      FindMenuAction(window(), "Reconstruction", "Global reconstruction");
  ASSERT_NE(run, nullptr);
  ASSERT_TRUE(run->isEnabled());
  bool in_toolbar = false;
  for (QToolBar* toolbar : window_->findChildren<QToolBar*>()) {
    in_toolbar = in_toolbar || toolbar->actions().contains(run);
  }
  EXPECT_TRUE(in_toolbar);
  QAction* options_action = FindMenuAction(window(), "Reconstruction",
                                           "Global reconstruction options...");
  ASSERT_NE(options_action, nullptr);

  // The options dialog lists every table entry, grouped by stage.
  options_action->trigger();
  ProcessEventsFor(100);
  EXPECT_TRUE(ui_->OptionsDialog()->isVisible());
  glomap::GlobalMapperOptions table_options;
  EXPECT_EQ(
      ui_->OptionsDialog()->NumOptions(),
      static_cast<int>(glomap::GlobalMapperOptionTable(&table_options).size()));
  EXPECT_GT(ui_->OptionsDialog()->Groups().size(), 1);
  ui_->OptionsDialog()->grab().save(QString(GLOMAP_BINARY_DIR) +
                                    "/gui_options_dialog.png");
  EXPECT_TRUE(ui_->OptionsDialog()->Apply());
  ui_->OptionsDialog()->hide();
  EXPECT_EQ(ui_->Options()->random_seed, 7);

  // File > Save project keeps the options beside the project, and leaves
  // the project file readable by stock COLMAP 3.8 (which rejects unknown
  // keys).
  const std::string options_path =
      GlobalReconstructionUi::OptionsFilePath(project_path_);
  fs::remove(options_path);
  ui_->Options()->num_threads = 2;
  QAction* save = FindMenuAction(window(), "File", "Save project");
  ASSERT_NE(save, nullptr);
  save->trigger();
  glomap::GlobalMapperOptions reread;
  ASSERT_TRUE(glomap::ReadGlobalMapperOptionsFile(options_path, &reread));
  EXPECT_EQ(reread.random_seed, 7);
  EXPECT_EQ(reread.num_threads, 2);
  {
    OptionManager stock_reader;
    stock_reader.AddAllOptions();
    EXPECT_TRUE(stock_reader.Read(project_path_));
    std::ifstream project_file(project_path_);
    const std::string project_text(
        (std::istreambuf_iterator<char>(project_file)),
        std::istreambuf_iterator<char>());
    EXPECT_EQ(project_text.find("GlobalMapper"), std::string::npos);
  }

  // Any message box during the run is a failure: record and close it.
  RecordMessages(/*answer_yes=*/false);

  QElapsedTimer run_timer;
  run_timer.start();
  run->trigger();
  EXPECT_TRUE(ui_->IsRunning());
  EXPECT_FALSE(run->isEnabled()) << "The action must be blocked while running";
  int max_stage_seen = -1;
  QString progress_text;
  bool running_screenshot_saved = false;
  ASSERT_TRUE(WaitUntil(
      [&]() {
        for (QLabel* label : window_->statusBar()->findChildren<QLabel*>()) {
          if (label->text().startsWith("Global reconstruction: Stage")) {
            progress_text = label->text();
            max_stage_seen = std::max(
                max_stage_seen,
                progress_text.section(' ', 3, 3).section('/', 0, 0).toInt());
          }
        }
        // One screenshot while bundle adjustment refines the model.
        if (!running_screenshot_saved &&
            progress_text.contains("Bundle adjustment")) {
          running_screenshot_saved = window_->grab().save(
              QString(GLOMAP_BINARY_DIR) + "/gui_screenshot_running.png");
        }
        return !ui_->IsRunning();
      },
      kRunTimeoutMs))
      << "Global reconstruction did not finish";
  // printf: COLMAP's log widget has taken over std::cout and std::cerr.
  printf("Global reconstruction took %.1f s; last progress: %s\n",
         run_timer.elapsed() / 1000.0, progress_text.toStdString().c_str());
  EXPECT_GE(max_stage_seen, 2) << "The status bar never showed the stages";
  // After global positioning, after each BA round, at the end.
  EXPECT_GE(ui_->NumModelUpdatesShown(), 3);
  EXPECT_TRUE(messages_.isEmpty()) << messages_.join("\n").toStdString();
  ASSERT_TRUE(ui_->LastStatus().ok()) << ui_->LastStatus().message();
  EXPECT_TRUE(run->isEnabled());

  // One model per camera cluster; fountain has one camera and 11 images.
  const ReconstructionManager& models = ui_->Models();
  ASSERT_GE(models.Size(), 1u);
  const Reconstruction& model = models.Get(0);
  EXPECT_EQ(model.NumRegImages(), 11u);
  EXPECT_GT(model.NumPoints3D(), 1000u);

  // The stock statistics window shows real values.
  QAction* stats = FindMenuAction(window(), "Extras", "Show model statistics");
  ASSERT_NE(stats, nullptr);
  stats->trigger();
  ProcessEventsFor(100);
  EXPECT_EQ(StatisticsValue(window(), "Registered images"), "11");
  const double mean_error =
      StatisticsValue(window(), "Mean reprojection error").toDouble();
  EXPECT_GT(mean_error, 0.0);
  EXPECT_LT(mean_error, 4.0);
  EXPECT_GT(StatisticsValue(window(), "Mean track length").toDouble(), 2.0);
  for (QWidget* widget : QApplication::topLevelWidgets()) {
    if (widget->windowTitle() == "Reconstruction statistics") widget->hide();
  }

  // The viewer draws the model (Mesa's software OpenGL under Xvfb).
  ProcessEventsFor(300);
  QWidget* viewer_widget = window_->centralWidget();
  const QRect viewer_rect(viewer_widget->mapTo(window(), QPoint(0, 0)),
                          viewer_widget->size());
  QImage screenshot = window_->grab().toImage();
  EXPECT_GT(DrawnFraction(screenshot, viewer_rect), 0.002)
      << "The model viewer shows nothing";

  // Screenshot of the whole main window, zoomed in as with the mouse wheel
  // (unzoomed if that loses the model).
  ModelViewerWidget* viewer = static_cast<ModelViewerWidget*>(viewer_widget);
  viewer->ChangeFocusDistance(600);
  viewer->ChangePointSize(500);
  ProcessEventsFor(300);
  const QImage zoomed = window_->grab().toImage();
  if (DrawnFraction(zoomed, viewer_rect) > 0.01) screenshot = zoomed;
  const std::string screenshot_path =
      std::string(GLOMAP_BINARY_DIR) + "/gui_screenshot.png";
  ASSERT_TRUE(screenshot.save(QString::fromStdString(screenshot_path)));
  printf("Screenshot: %s\n", screenshot_path.c_str());

  // File > Export writes the selected (largest) model.
  const std::string export_dir = test_dir_ + "/export";
  fs::create_directories(export_dir);
  ModalDialogHandler file_dialogs([&](QWidget* modal) {
    if (QFileDialog* dialog = qobject_cast<QFileDialog*>(modal)) {
      // With nothing selected, a folder dialog returns its current folder.
      dialog->setDirectory(QString::fromStdString(export_dir));
      // Public in QDialog, virtual: runs QFileDialog::accept().
      static_cast<QDialog*>(dialog)->accept();
      return true;
    }
    return false;
  });
  QAction* export_action = FindMenuAction(window(), "File", "Export model");
  ASSERT_NE(export_action, nullptr);
  export_action->trigger();
  ASSERT_TRUE(WaitUntil(
      [&]() { return fs::exists(export_dir + "/points3D.bin"); }, 60000));
  ProcessEventsFor(500);
  Reconstruction exported;
  exported.ReadBinary(export_dir);
  EXPECT_EQ(exported.NumRegImages(), 11u);
  EXPECT_EQ(exported.NumPoints3D(), model.NumPoints3D());
}

// Cancel in the middle of a run, in three different stages of one window:
// each run stops within a second, leaves no model and the window usable. A
// synthetic project of 100 images runs long enough that every stage named
// here is reached while the run goes on.
TEST_F(GlobalReconstructionGui, CancelStopsMidRunWithinASecond) {
  ASSERT_TRUE(WriteSyntheticProject("global_reconstruction_gui_cancel", 100));
  OpenProject();
  RunRansacOnEveryPair();
  RecordMessages(/*answer_yes=*/false);

  for (const char* stage :
       {"Relative poses", "Global positioning", "Bundle adjustment"}) {
    SCOPED_TRACE(stage);
    ASSERT_TRUE(RunUntilStage(stage)) << "The run ended before " << stage;
    ASSERT_NO_FATAL_FAILURE(CancelPromptly(std::string("in stage ") + stage));
    EXPECT_TRUE(ui_->RunAction()->isEnabled());
  }
  EXPECT_TRUE(messages_.isEmpty()) << messages_.join("\n").toStdString();
}

// Seconds shown by the status bar's "Time dd:hh:mm:ss" label.
int TimeLabelSeconds(const QString& text) {
  const QStringList parts = text.section(' ', 1, 1).split(':');
  if (parts.size() != 4) return -1;
  return ((parts[0].toInt() * 24 + parts[1].toInt()) * 60 + parts[2].toInt()) *
             60 +
         parts[3].toInt();
}

// What the user sees of a run besides the model: the Log dock shows the
// pipeline's glog lines as the command prints them, while they are printed;
// the status bar's "Time" counts; "Pause" holds the run at its next check
// (neither the stage, the log nor the clock moves) until "Resume", and the
// run then ends with its models.
TEST_F(GlobalReconstructionGui, LogTimeAndPauseFollowTheRun) {
  ASSERT_TRUE(WriteSyntheticProject("global_reconstruction_gui_pause", 60));
  OpenProject();
  RecordMessages(/*answer_yes=*/false);
  const QString time_zero = "Time 00:00:00:00";
  auto time_label = [&]() { return StatusBarLabel(window(), "Time "); };
  auto progress_label = [&]() {
    return StatusBarLabel(window(), "Global reconstruction");
  };

  QElapsedTimer run_timer;
  run_timer.start();
  ui_->RunAction()->trigger();
  ASSERT_TRUE(ui_->IsRunning());
  EXPECT_EQ(time_label(), time_zero);
  ASSERT_TRUE(WaitUntil(
      [&]() {
        return LogDockText(window()).contains("Stage Database:") ||
               !ui_->IsRunning();
      },
      kRunTimeoutMs));
  EXPECT_TRUE(ui_->IsRunning()) << "The log appeared only after the run";
  ASSERT_TRUE(WaitUntil(
      [&]() { return time_label() != time_zero || !ui_->IsRunning(); },
      kRunTimeoutMs));
  ASSERT_TRUE(ui_->IsRunning()) << "The clock did not count during the run";

  // A second into the run: in "Relative poses", the longest stage here.
  QPushButton* pause = StatusBarButton(window(), "Pause");
  ASSERT_NE(pause, nullptr);
  QElapsedTimer pause_timer;
  pause_timer.start();
  pause->click();
  EXPECT_EQ(pause->text(), "Resume");
  EXPECT_TRUE(ui_->IsPaused());
  ASSERT_TRUE(
      WaitUntil([&]() { return progress_label().contains(", paused"); }, 5000))
      << progress_label().toStdString();
  printf("Pausing took %lld ms: %s\n", pause_timer.elapsed(),
         progress_label().toStdString().c_str());
  // Lines logged just before the pause reach the widget within its 100 ms
  // flush.
  ProcessEventsFor(300);
  const QString paused_progress = progress_label();
  const QString paused_time = time_label();
  // "Time dd:hh:mm:ss" and our "— mm:ss" show the same clock.
  const QStringList progress_time =
      paused_progress.section(QChar(0x2014), 1).trimmed().split(':');
  ASSERT_EQ(progress_time.size(), 2) << paused_progress.toStdString();
  EXPECT_EQ(TimeLabelSeconds(paused_time),
            progress_time[0].toInt() * 60 + progress_time[1].toInt())
      << paused_time.toStdString();
  const QString paused_log = LogDockText(window());
  ProcessEventsFor(1500);
  EXPECT_TRUE(ui_->IsRunning());
  EXPECT_EQ(progress_label(), paused_progress) << "The run went on";
  EXPECT_EQ(time_label(), paused_time) << "The clock counted the pause";
  EXPECT_EQ(LogDockText(window()), paused_log) << "The run went on";

  pause->click();
  EXPECT_EQ(pause->text(), "Pause");
  EXPECT_FALSE(ui_->IsPaused());
  ASSERT_TRUE(WaitUntil([&]() { return !ui_->IsRunning(); }, kRunTimeoutMs));
  const qint64 run_ms = run_timer.elapsed();
  ASSERT_TRUE(ui_->LastStatus().ok()) << ui_->LastStatus().message();
  EXPECT_GE(ui_->Models().Size(), 1u);
  printf("Run with a pause took %.1f s; %s\n", run_ms / 1000.0,
         StatusBarText(window()).simplified().toStdString().c_str());

  // Every stage's line, once each (nothing reached the dock twice), in
  // glog's format as the command prints it. The widget shows its queue
  // every 100 ms.
  ASSERT_TRUE(WaitUntil(
      [&]() {
        return LogDockText(window()).contains("Global mapper finished");
      },
      2000));
  const QString log = LogDockText(window());
  for (const char* stage :
       {"Database", "Relative poses", "Global positioning", "Bundle adjustment",
        "Retriangulation", "Camera clustering"}) {
    EXPECT_EQ(log.count(QString("] Stage %1: ").arg(stage)), 1) << stage;
  }
  EXPECT_TRUE(
      log.contains(QRegularExpression(R"(^I\d{4,8} \d\d:\d\d:\d\d\.\d{6} +\d+ )"
                                      R"(global_mapper\.cc:\d+\] Stage )"
                                      R"(Retriangulation: )",
                                      QRegularExpression::MultilineOption)))
      << log.toStdString();

  // The clock stopped with the run and did not count the pause.
  const QString final_time = time_label();
  ProcessEventsFor(1200);
  EXPECT_EQ(time_label(), final_time);
  EXPECT_GE(TimeLabelSeconds(final_time), 1);
  EXPECT_LE(TimeLabelSeconds(final_time), run_ms / 1000.0 - 1.4)
      << final_time.toStdString();
  EXPECT_TRUE(messages_.isEmpty()) << messages_.join("\n").toStdString();
}

// A paused run still stops promptly: Cancel while paused takes under a
// second, and closing the window while paused does not hang.
TEST_F(GlobalReconstructionGui, CancelAndCloseWhilePaused) {
  ASSERT_TRUE(
      WriteSyntheticProject("global_reconstruction_gui_pause_stop", 60));
  OpenProject();
  RunRansacOnEveryPair();
  // "Do you really want to quit?" -> Yes; any other message is a failure.
  RecordMessages(/*answer_yes=*/true);
  // Starts a run and pauses it in its third stage.
  auto run_and_pause = [&]() {
    ASSERT_TRUE(RunUntilStage("Relative poses"))
        << "The run ended before Relative poses";
    QPushButton* pause = StatusBarButton(window(), "Pause");
    ASSERT_NE(pause, nullptr);
    pause->click();
    ASSERT_TRUE(WaitUntil(
        [&]() { return StatusBarText(window()).contains(", paused"); }, 5000));
  };

  run_and_pause();
  if (HasFatalFailure()) return;
  ASSERT_NO_FATAL_FAILURE(CancelPromptly("while paused"));
  EXPECT_EQ(StatusBarButton(window(), "Resume"), nullptr);
  EXPECT_TRUE(messages_.isEmpty()) << messages_.join("\n").toStdString();

  run_and_pause();
  if (HasFatalFailure()) return;
  CloseStopsTheRun("Closing while paused", 3000);
}

// An exception that escapes a thread the GUI does not own (a Ceres worker)
// ends the program with one error line and exit code 1, not SIGABRT; the
// global reconstruction installs that handler with its menu entry.
TEST(GlobalReconstructionGuiDeathTest,
     ExceptionInAForeignThreadIsOneErrorLine) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_EXIT(
      {
        InstallTerminateHandler();
        std::thread([]() { throw std::runtime_error("boom"); }).join();
      },
      ::testing::ExitedWithCode(1), "ERROR: Internal error: boom");
  EXPECT_EXIT(
      {
        InstallTerminateHandler();
        std::thread([]() { throw std::bad_alloc(); }).join();
      },
      ::testing::ExitedWithCode(1), "ERROR: Out of memory");
}

TEST_F(GlobalReconstructionGui, ClosingTheWindowStopsTheRun) {
  ASSERT_TRUE(WriteSyntheticProject("global_reconstruction_gui_close", 60));
  OpenProject();
  RunRansacOnEveryPair();
  // "Do you really want to quit?" -> Yes.
  RecordMessages(/*answer_yes=*/true);

  ASSERT_TRUE(RunUntilStage("Relative poses"))
      << "The run ended before Relative poses";
  CloseStopsTheRun("Closing", 10000);
}

// The options dialog shows every GlobalMapper.* option with its default
// (among them those that were constants in the code before issue 13), and
// refuses a value out of range with the command line's message, which names
// the option and its range.
TEST_F(GlobalReconstructionGui, OptionsDialogShowsDefaultsAndNamesBadValues) {
  glomap::GlobalMapperOptions options;
  GlobalMapperOptionsDialog dialog(nullptr, &options, {});
  dialog.show();
  ProcessEventsFor(100);
  // The editor in the row whose label is `key`.
  auto editor = [&dialog](const std::string& key) -> QWidget* {
    for (QLabel* label : dialog.findChildren<QLabel*>()) {
      if (label->text().toStdString() != key) continue;
      QFormLayout* form =
          qobject_cast<QFormLayout*>(label->parentWidget()->layout());
      if (form == nullptr) continue;
      int row = -1;
      QFormLayout::ItemRole role;
      form->getWidgetPosition(label, &row, &role);
      return form->itemAt(row, QFormLayout::FieldRole)->widget();
    }
    return nullptr;
  };
  glomap::GlobalMapperOptions defaults;
  for (const glomap::GlobalMapperOptionEntry& entry :
       glomap::GlobalMapperOptionTable(&defaults)) {
    QWidget* widget = editor(entry.key);
    ASSERT_NE(widget, nullptr) << entry.key;
    std::visit(
        [&](auto* value) {
          using T = std::remove_pointer_t<decltype(value)>;
          if constexpr (std::is_same_v<T, bool>) {
            QCheckBox* box = qobject_cast<QCheckBox*>(widget);
            ASSERT_NE(box, nullptr) << entry.key;
            EXPECT_EQ(box->isChecked(), *value) << entry.key;
          } else if constexpr (std::is_same_v<T, int>) {
            QSpinBox* spin_box = qobject_cast<QSpinBox*>(widget);
            ASSERT_NE(spin_box, nullptr) << entry.key;
            EXPECT_EQ(spin_box->value(), *value) << entry.key;
          } else {
            QLineEdit* line_edit = qobject_cast<QLineEdit*>(widget);
            ASSERT_NE(line_edit, nullptr) << entry.key;
            EXPECT_EQ(QLocale::c().toDouble(line_edit->text()), *value)
                << entry.key;
          }
        },
        entry.value);
  }

  QSpinBox* random_start =
      qobject_cast<QSpinBox*>(editor("gp_random_start_max_num_images"));
  ASSERT_NE(random_start, nullptr);
  EXPECT_EQ(random_start->value(), 500);
  random_start->setValue(-5);
  QStringList messages;
  {
    ModalDialogHandler message_boxes(
        RecordMessageBoxes(&messages, /*answer_yes=*/false, /*accept=*/true));
    EXPECT_FALSE(dialog.Apply());
  }
  ASSERT_EQ(messages.size(), 1);
  EXPECT_EQ(messages.front().toStdString(),
            "GlobalMapper.gp_random_start_max_num_images must be >= 0, is -5");
  EXPECT_EQ(options.global_positioning.random_start_max_num_images, 500);
  random_start->setValue(100);
  EXPECT_TRUE(dialog.Apply());
  EXPECT_EQ(options.global_positioning.random_start_max_num_images, 100);
}

// The label of option `key` in the options dialog, or null.
QLabel* OptionLabel(QWidget* dialog, const std::string& key) {
  for (QLabel* label : dialog->findChildren<QLabel*>()) {
    if (label->text().toStdString() == key) return label;
  }
  return nullptr;
}

// Issue 30: the options dialog shows the basic options (those of
// `colmap global_mapper -h`); its "Advanced" toggle, off when the dialog is
// made, shows the others too, and hides them again. Values of hidden options
// are kept and applied, and a refused advanced value shows its option.
TEST_F(GlobalReconstructionGui, OptionsDialogShowsAdvancedOptionsWhenToggled) {
  glomap::GlobalMapperOptions options;
  GlobalMapperOptionsDialog dialog(nullptr, &options, {});
  dialog.show();
  ProcessEventsFor(100);
  QCheckBox* advanced = dialog.AdvancedToggle();
  ASSERT_NE(advanced, nullptr);
  EXPECT_EQ(advanced->text(), "Advanced");
  EXPECT_TRUE(advanced->isVisible());
  EXPECT_FALSE(advanced->isChecked());
  QListWidget* groups = dialog.findChild<QListWidget*>();
  ASSERT_NE(groups, nullptr);
  glomap::GlobalMapperOptions defaults;
  const std::vector<glomap::GlobalMapperOptionEntry> table =
      glomap::GlobalMapperOptionTable(&defaults);
  const auto is_basic = [](const glomap::GlobalMapperOptionEntry& entry) {
    return entry.tier == glomap::GlobalMapperOptionTier::kBasic;
  };
  const size_t num_basic = std::count_if(table.begin(), table.end(), is_basic);
  ASSERT_GT(num_basic, 0u);
  ASSERT_LT(num_basic, table.size());
  ASSERT_EQ(groups->count(), dialog.Groups().size());

  // Opens every listed group's page and counts the option labels on it that
  // are visible, checking each against `show_advanced`.
  const auto count_shown = [&](bool show_advanced) {
    size_t num_shown = 0;
    for (int i = 0; i < groups->count(); ++i) {
      const std::string group = groups->item(i)->text().toStdString();
      const bool has_basic =
          std::any_of(table.begin(), table.end(), [&](const auto& entry) {
            return entry.group == group && is_basic(entry);
          });
      EXPECT_EQ(groups->item(i)->isHidden(), !show_advanced && !has_basic)
          << group;
      if (groups->item(i)->isHidden()) continue;
      groups->setCurrentRow(i);
      ProcessEventsFor(20);
      for (const auto& entry : table) {
        if (entry.group != group) continue;
        QLabel* label = OptionLabel(&dialog, entry.key);
        if (label == nullptr) {
          ADD_FAILURE() << entry.key;
          continue;
        }
        EXPECT_EQ(label->isVisible(), show_advanced || is_basic(entry))
            << entry.key;
        num_shown += label->isVisible();
      }
    }
    return num_shown;
  };
  EXPECT_EQ(count_shown(false), num_basic);
  advanced->click();
  ProcessEventsFor(50);
  EXPECT_TRUE(advanced->isChecked());
  EXPECT_EQ(count_shown(true), table.size());

  // An advanced value set while shown is kept when hidden, and applied.
  QLabel* random_start_label =
      OptionLabel(&dialog, "gp_random_start_max_num_images");
  ASSERT_NE(random_start_label, nullptr);
  QFormLayout* form =
      qobject_cast<QFormLayout*>(random_start_label->parentWidget()->layout());
  ASSERT_NE(form, nullptr);
  int row = -1;
  QFormLayout::ItemRole role;
  form->getWidgetPosition(random_start_label, &row, &role);
  QSpinBox* random_start = qobject_cast<QSpinBox*>(
      form->itemAt(row, QFormLayout::FieldRole)->widget());
  ASSERT_NE(random_start, nullptr);
  random_start->setValue(77);
  advanced->click();
  ProcessEventsFor(50);
  EXPECT_FALSE(advanced->isChecked());
  EXPECT_EQ(count_shown(false), num_basic);
  EXPECT_EQ(random_start->value(), 77);
  EXPECT_TRUE(dialog.Apply());
  EXPECT_EQ(options.global_positioning.random_start_max_num_images, 77);

  // A refused advanced value turns "Advanced" on and shows the option.
  random_start->setValue(-1);
  QStringList messages;
  {
    ModalDialogHandler message_boxes(
        RecordMessageBoxes(&messages, /*answer_yes=*/false, /*accept=*/true));
    EXPECT_FALSE(dialog.Apply());
  }
  ASSERT_EQ(messages.size(), 1);
  EXPECT_TRUE(advanced->isChecked());
  ProcessEventsFor(50);
  EXPECT_TRUE(random_start->isVisible());
  EXPECT_EQ(options.global_positioning.random_start_max_num_images, 77);
}

// The push button of `widget` labelled `text`, or null.
QPushButton* ButtonWithText(QWidget* widget, const QString& text) {
  for (QPushButton* button : widget->findChildren<QPushButton*>()) {
    if (button->text() == text) return button;
  }
  return nullptr;
}

// Reconstruction > Automatic reconstruction with the mapper set to Global,
// on templeRing's 47 images: COLMAP 3.8's extraction and matching in the
// widget's progress dialog, then the global mapper with its progress in the
// status bar; the model shows in the viewer and is written to
// WORKSPACE/sparse/0. A second run on the same workspace reuses the
// database and replaces the model.
TEST_F(GlobalReconstructionGui, AutomaticReconstructionWithTheGlobalMapper) {
  const std::string datasets = glomap::testing::SharedDatasetsDir();
  const fs::path source = fs::path(datasets) / "templeRing" / "images";
  if (datasets.empty() || !fs::is_directory(source) || fs::is_empty(source)) {
    GTEST_SKIP() << "templeRing's images are not in the shared datasets.";
  }
  ASSERT_TRUE(WriteSyntheticProject("automatic_global_gui", 10));
  const fs::path images = fs::path(test_dir_) / "temple_images";
  fs::create_directories(images);
  std::vector<fs::path> sources;
  for (const auto& entry : fs::directory_iterator(source)) {
    sources.push_back(entry.path());
  }
  std::sort(sources.begin(), sources.end());
  for (const fs::path& image : sources) {
    fs::create_symlink(image, images / image.filename());
  }
  const fs::path workspace = fs::path(test_dir_) / "workspace";
  fs::create_directories(workspace);

  OpenProject(QSize(1400, 860));
  RecordMessages(/*answer_yes=*/false);
  QWidget* widget = OpenAutomaticReconstruction(workspace, images);
  ASSERT_NE(widget, nullptr);
  ASSERT_TRUE(widget->isVisible());

  // The mapper choice, beside the stock fields; Incremental by default.
  QComboBox* mapper = qobject_cast<QComboBox*>(FieldOfRow(widget, "Mapper"));
  ASSERT_NE(mapper, nullptr);
  EXPECT_EQ(mapper, ui_->AutomaticMapperChoice());
  EXPECT_EQ(mapper->currentText(), "Incremental");
  mapper->setCurrentIndex(mapper->findText("Global"));
  ASSERT_EQ(mapper->currentText(), "Global");
  QPushButton* options_button =
      ButtonWithText(widget, "Global mapper options...");
  QPushButton* run_button = ButtonWithText(widget, "Run");
  ASSERT_NE(options_button, nullptr);
  ASSERT_NE(run_button, nullptr);
  options_button->click();
  ProcessEventsFor(100);
  EXPECT_TRUE(ui_->OptionsDialog()->isVisible());
  ui_->OptionsDialog()->hide();

  const auto run_to_the_end = [&](const std::string& what) {
    QElapsedTimer timer;
    timer.start();
    run_button->click();
    EXPECT_TRUE(ui_->IsExtractingAndMatching());
    bool saw_global_stage = false;
    EXPECT_TRUE(WaitUntil(
        [&]() {
          saw_global_stage =
              saw_global_stage ||
              !StatusBarLabel(window(), "Global reconstruction: Stage")
                   .isEmpty();
          return !ui_->IsExtractingAndMatching() && !ui_->IsRunning() &&
                 !StatusBarLabel(window(), "Global reconstruction: 1 model")
                      .isEmpty();
        },
        kRunTimeoutMs))
        << StatusBarText(window()).toStdString()
        << messages_.join("\n").toStdString();
    printf("Automatic reconstruction (%s) took %lld ms\n", what.c_str(),
           timer.elapsed());
    EXPECT_TRUE(saw_global_stage);
  };
  run_to_the_end("first run");
  EXPECT_TRUE(ui_->LastStatus().ok()) << ui_->LastStatus().message();
  ASSERT_EQ(ui_->Models().Size(), 1u);
  EXPECT_EQ(ui_->Models().Get(0).NumRegImages(), sources.size());
  EXPECT_GT(ui_->NumModelUpdatesShown(), 0);
  EXPECT_TRUE(StatusBarLabel(window(), "Global reconstruction: 1 model")
                  .contains("written to"));
  Reconstruction written;
  written.ReadBinary((workspace / "sparse" / "0").string());
  EXPECT_EQ(written.NumRegImages(), sources.size());
  EXPECT_TRUE(messages_.isEmpty()) << messages_.join("\n").toStdString();
  // The viewer draws the model.
  ProcessEventsFor(300);
  QWidget* viewer = window_->centralWidget();
  const QRect viewer_rect(viewer->mapTo(window(), QPoint(0, 0)),
                          viewer->size());
  EXPECT_GT(DrawnFraction(window_->grab().toImage(), viewer_rect), 0.002);

  // Again on the same workspace: the database's features are kept.
  const auto num_keypoints = [&]() {
    Database database((workspace / "database.db").string());
    return database.NumKeypoints();
  };
  const size_t keypoints_before = num_keypoints();
  run_to_the_end("rerun");
  EXPECT_EQ(num_keypoints(), keypoints_before);
  EXPECT_EQ(ui_->Models().Size(), 1u);
  EXPECT_TRUE(messages_.isEmpty()) << messages_.join("\n").toStdString();
}

// Automatic reconstruction with the Global mapper, cancelled twice: in the
// progress dialog while extracting, then from the status bar while the
// global mapper runs. Neither leaves a model or a sparse folder, and the
// workspace's database stays sound and usable (the second run goes on from
// the features the first one stored).
TEST_F(GlobalReconstructionGui, AutomaticReconstructionCancelKeepsWorkspace) {
  const std::string datasets = glomap::testing::SharedDatasetsDir();
  const fs::path source = fs::path(datasets) / "templeRing" / "images";
  if (datasets.empty() || !fs::is_directory(source) || fs::is_empty(source)) {
    GTEST_SKIP() << "templeRing's images are not in the shared datasets.";
  }
  ASSERT_TRUE(WriteSyntheticProject("automatic_global_gui_cancel", 10));
  const fs::path workspace = fs::path(test_dir_) / "workspace";
  fs::create_directories(workspace);
  OpenProject(QSize(1400, 860));
  RecordMessages(/*answer_yes=*/false);
  QWidget* widget = OpenAutomaticReconstruction(workspace, source);
  ASSERT_NE(widget, nullptr);
  ui_->AutomaticMapperChoice()->setCurrentIndex(1);
  QPushButton* run_button = ButtonWithText(widget, "Run");
  ASSERT_NE(run_button, nullptr);
  const fs::path database = workspace / "database.db";

  // 1. Cancel in the progress dialog while extracting.
  run_button->click();
  ASSERT_TRUE(ui_->IsExtractingAndMatching());
  ProcessEventsFor(1500);
  QProgressDialog* progress = nullptr;
  for (QProgressDialog* dialog : widget->findChildren<QProgressDialog*>()) {
    if (dialog->isVisible()) progress = dialog;
  }
  ASSERT_NE(progress, nullptr);
  QPushButton* cancel_extraction = progress->findChild<QPushButton*>();
  ASSERT_NE(cancel_extraction, nullptr);
  cancel_extraction->click();
  ASSERT_TRUE(
      WaitUntil([&]() { return !ui_->IsExtractingAndMatching(); }, 60000));
  ProcessEventsFor(300);
  EXPECT_FALSE(ui_->IsRunning());
  EXPECT_FALSE(fs::exists(workspace / "sparse"));
  size_t num_images_kept = 0;
  {
    Database opened(database.string());
    num_images_kept = opened.NumImages();
  }
  EXPECT_LT(num_images_kept, 47u);

  // 2. Run again, cancel once the global mapper runs.
  run_button->click();
  ASSERT_TRUE(WaitUntil(
      [&]() {
        return ui_->IsRunning() ||
               (!ui_->IsExtractingAndMatching() && !messages_.isEmpty());
      },
      kRunTimeoutMs))
      << messages_.join("\n").toStdString();
  ASSERT_TRUE(ui_->IsRunning()) << messages_.join("\n").toStdString();
  CancelPromptly("automatic reconstruction, global mapper");
  EXPECT_FALSE(fs::exists(workspace / "sparse"));
  {
    Database opened(database.string());
    EXPECT_EQ(opened.NumImages(), 47u);
    EXPECT_GT(opened.NumVerifiedImagePairs(), 0u);
  }
  EXPECT_TRUE(messages_.isEmpty()) << messages_.join("\n").toStdString();
}

// Closing the window while Automatic reconstruction (Global) extracts
// features stops the extraction and closes promptly, without a crash.
TEST_F(GlobalReconstructionGui, ClosingDuringExtractionStopsIt) {
  const std::string datasets = glomap::testing::SharedDatasetsDir();
  const fs::path source = fs::path(datasets) / "templeRing" / "images";
  if (datasets.empty() || !fs::is_directory(source) || fs::is_empty(source)) {
    GTEST_SKIP() << "templeRing's images are not in the shared datasets.";
  }
  ASSERT_TRUE(WriteSyntheticProject("automatic_global_gui_close", 10));
  const fs::path workspace = fs::path(test_dir_) / "workspace";
  fs::create_directories(workspace);
  OpenProject(QSize(1400, 860));
  QWidget* widget = OpenAutomaticReconstruction(workspace, source);
  ASSERT_NE(widget, nullptr);
  ui_->AutomaticMapperChoice()->setCurrentIndex(1);
  QPushButton* run_button = ButtonWithText(widget, "Run");
  ASSERT_NE(run_button, nullptr);
  run_button->click();
  ASSERT_TRUE(ui_->IsExtractingAndMatching());
  ProcessEventsFor(1000);
  RecordMessages(/*answer_yes=*/true);
  CloseStopsTheRun("Closing during extraction", 5000);
  EXPECT_FALSE(ui_->IsExtractingAndMatching());
  EXPECT_FALSE(fs::exists(workspace / "sparse"));
}

TEST_F(GlobalReconstructionGui, ErrorShowsTheCommandLineMessage) {
  if (!WriteFountainProject("global_reconstruction_gui_error")) {
    GTEST_SKIP() << "Shared dataset fountain-P11 not found.";
  }
  {
    // Images and features but no matches.
    Database database(test_dir_ + "/database.db");
    database.ClearMatches();
    database.ClearTwoViewGeometries();
  }
  OpenProject();
  RecordMessages(/*answer_yes=*/false, /*accept=*/true);
  ui_->RunAction()->trigger();
  ASSERT_TRUE(WaitUntil([&]() { return !ui_->IsRunning(); }, 120000));
  ASSERT_TRUE(WaitUntil([&]() { return !messages_.isEmpty(); }, 5000));
  EXPECT_FALSE(ui_->LastStatus().ok());
  EXPECT_FALSE(ui_->LastStatus().cancelled());
  printf("Message box: %s\n", messages_.front().toStdString().c_str());
  EXPECT_EQ(messages_.front().toStdString(), ui_->LastStatus().message());
  EXPECT_EQ(ui_->Models().Size(), 0u);
  EXPECT_TRUE(ui_->RunAction()->isEnabled());
}

}  // namespace
}  // namespace colmap

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  // COLMAP's icons and shaders live in a static library's resource object,
  // which `colmap` itself registers the same way (src/exe/colmap.cc).
  Q_INIT_RESOURCE(resources);
  QApplication app(argc, argv);
  return RUN_ALL_TESTS();
}
