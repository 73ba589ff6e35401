#include "gui/global_reconstruction_ui.h"

#include <QStringList>
#include <algorithm>
#include <iostream>
#include <string>
#include <vector>

#include "colmap_ext/extraction_and_matching.h"
#include "colmap_ext/global_mapper_options.h"
#include "colmap_ext/global_mapper_run.h"
#include "colmap_ext/terminate_handler.h"
#include "feature/extraction.h"
#include "feature/matching.h"
#include "gui/global_mapper_options_dialog.h"
#include "ui/automatic_reconstruction_widget.h"
#include "ui/main_window.h"
#include "ui/thread_control_widget.h"
#include "util/misc.h"
#include "util/option_manager.h"

namespace colmap {
namespace {

// Inserts `action` right after `after` in a menu or tool bar, or at its end.
void InsertActionAfter(QWidget* container, QAction* after, QAction* action) {
  const QList<QAction*> actions = container->actions();
  const int index = actions.indexOf(after);
  if (index >= 0 && index + 1 < actions.size()) {
    container->insertAction(actions[index + 1], action);
  } else {
    container->addAction(action);
  }
}

// "mm:ss", or "h:mm:ss" from one hour on.
QString FormatElapsed(double elapsed_seconds) {
  const qint64 seconds = static_cast<qint64>(elapsed_seconds);
  if (seconds < 3600) {
    return QString::asprintf("%02lld:%02lld", seconds / 60, seconds % 60);
  }
  return QString::asprintf("%lld:%02lld:%02lld", seconds / 3600,
                           (seconds / 60) % 60, seconds % 60);
}

// glog prints with C stdio (or into files), past COLMAP's LogWidget, which
// captures only the C++ streams. This sink hands each line, in the format the
// command prints, to std::clog: while the window lives that is the LogWidget,
// whose stream buffer may be written from any thread (a mutex-guarded queue
// that a timer flushes on the GUI thread), and it keeps the lines in order
// with what the pipeline and COLMAP print to std::cout. Once the widget is
// gone it has given the stream back to stderr, so a line logged by a worker
// that outlives it is never written into a destroyed widget.
class LogDockSink : public google::LogSink {
 public:
  void send(google::LogSeverity severity, const char* /*full_filename*/,
            const char* base_filename, int line,
            const google::LogMessageTime& time, const char* message,
            size_t message_len) override {
    std::string text =
        ToString(severity, base_filename, line, time, message, message_len);
    text += '\n';
    // One write, so that lines of concurrent threads do not interleave.
    std::clog.write(text.data(), static_cast<std::streamsize>(text.size()));
  }
};

}  // namespace

GlobalReconstructionUi* InstallGlobalReconstruction(MainWindow* main_window) {
  // An exception that escapes a Ceres or OpenMP thread during a run ends the
  // GUI with one error line, as on the command line, not with SIGABRT.
  InstallTerminateHandler();
  return new GlobalReconstructionUi(main_window);
}

GlobalReconstructionUi::GlobalReconstructionUi(MainWindow* main_window)
    : QObject(main_window), window_(main_window) {
  CreateActions();
  CreateStatusWidgets();
  ConnectProjectActions();
  InstallAutomaticMapperChoice();
  options_dialog_ = new GlobalMapperOptionsDialog(window_, &options_, [this]() {
    // Like a project file written by Save: keep the options with the
    // project as soon as it has a file.
    ReportExceptions([this]() {
      if (ExistsFile(*window_->options_.project_path)) SaveProjectOptions();
    });
  });
  // For the window's life rather than per run: the options' checks before a
  // run log their reasons too, and the Log dock is where the GUI points to.
  log_sink_ = std::make_unique<LogDockSink>();
  google::AddLogSink(log_sink_.get());
  // `colmap gui --project_path p.ini` opened a project before we existed.
  ReportExceptions([this]() { LoadProjectOptions(); });

  window_->installEventFilter(this);
  connect(qApp, &QCoreApplication::aboutToQuit, this, [this]() {
    if (IsRunning()) StopAndWait();
  });
}

GlobalReconstructionUi::~GlobalReconstructionUi() {
  // Normally the close event has stopped the run. If the window is destroyed
  // without closing, release the worker from any render request it waits on
  // (the requests go to this object) and let it finish.
  if (controller_) {
    cancelling_ = true;
    controller_->Stop();
    while (!controller_->IsFinished()) {
      QCoreApplication::removePostedEvents(this);
      QThread::msleep(5);
    }
    controller_->Wait();
  }
  google::RemoveLogSink(log_sink_.get());
}

const ReconstructionManager& GlobalReconstructionUi::Models() const {
  return window_->reconstruction_manager_;
}

std::string GlobalReconstructionUi::OptionsFilePath(
    const std::string& project_path) {
  std::string base = project_path;
  if (HasFileExtension(base, ".ini")) base.resize(base.size() - 4);
  return base + ".global_mapper.ini";
}

void GlobalReconstructionUi::CreateActions() {
  // The stock "start" icon with a small globe: the global variant.
  QPixmap icon(32, 32);
  icon.fill(Qt::transparent);
  {
    QPainter painter(&icon);
    painter.setRenderHint(QPainter::Antialiasing);
    painter.setRenderHint(QPainter::SmoothPixmapTransform);
    painter.drawPixmap(QRect(0, 0, 32, 32),
                       QIcon(":/media/reconstruction-start.png").pixmap(16));
    const QRectF globe(14.5, 14.5, 16, 16);
    painter.setPen(QPen(QColor(20, 70, 170), 2.5));
    painter.setBrush(QColor(255, 255, 255));
    painter.drawEllipse(globe);
    painter.setBrush(Qt::NoBrush);
    painter.drawEllipse(globe.adjusted(4.5, 0, -4.5, 0));
    painter.drawLine(QPointF(globe.left(), globe.center().y()),
                     QPointF(globe.right(), globe.center().y()));
  }

  action_run_ = new QAction(QIcon(icon), tr("Global reconstruction"), window_);
  action_run_->setToolTip(
      tr("Global reconstruction: all cameras at once (global mapper)"));
  connect(action_run_, &QAction::triggered, this,
          [this]() { ReportExceptions([this]() { Run(); }); });
  window_->blocking_actions_.push_back(action_run_);

  action_options_ =
      new QAction(QIcon(":/media/reconstruction-options.png"),
                  tr("Global reconstruction options..."), window_);
  connect(action_options_, &QAction::triggered, this,
          [this]() { ReportExceptions([this]() { ShowOptions(); }); });
  window_->blocking_actions_.push_back(action_options_);

  // Menu: after the incremental start/pause/step and after its options.
  for (QWidget* widget :
       window_->action_reconstruction_step_->associatedWidgets()) {
    if (QMenu* menu = qobject_cast<QMenu*>(widget)) {
      InsertActionAfter(menu, window_->action_reconstruction_step_,
                        action_run_);
      InsertActionAfter(menu, window_->action_reconstruction_options_,
                        action_options_);
    }
  }
  InsertActionAfter(window_->reconstruction_toolbar_,
                    window_->action_reconstruction_pause_, action_run_);
}

void GlobalReconstructionUi::CreateStatusWidgets() {
  QFont font;
  font.setPointSize(11);
  progress_label_ = new QLabel(window_);
  progress_label_->setFont(font);
  // Wide enough for the longest stage name, so the time does not jump.
  progress_label_->setMinimumWidth(QFontMetrics(font).horizontalAdvance(
      "Global reconstruction: Stage 10/11 Final pose verification, pausing "
      "\u2014 00:00:00"));
  progress_bar_ = new QProgressBar(window_);
  progress_bar_->setRange(0, glomap::GlobalMapper::kNumStages);
  progress_bar_->setFormat("%v/%m");
  progress_bar_->setMaximumWidth(160);
  pause_button_ = new QPushButton(tr("Pause"), window_);
  pause_button_->setToolTip(
      tr("Pause the global reconstruction at its next step, or resume it"));
  connect(pause_button_, &QPushButton::clicked, this,
          [this]() { ReportExceptions([this]() { TogglePause(); }); });
  cancel_button_ = new QPushButton(tr("Cancel"), window_);
  cancel_button_->setToolTip(tr("Stop the global reconstruction"));
  connect(cancel_button_, &QPushButton::clicked, this, [this]() { Cancel(); });

  QStatusBar* status_bar = window_->statusBar();
  status_bar->addPermanentWidget(progress_label_);
  status_bar->addPermanentWidget(progress_bar_);
  status_bar->addPermanentWidget(pause_button_);
  status_bar->addPermanentWidget(cancel_button_);
  progress_label_->hide();
  progress_bar_->hide();
  pause_button_->hide();
  cancel_button_->hide();

  progress_timer_ = new QTimer(this);
  connect(progress_timer_, &QTimer::timeout, this,
          [this]() { ReportExceptions([this]() { UpdateProgress(); }); });
}

void GlobalReconstructionUi::ConnectProjectActions() {
  // MainWindow's own handlers were connected first, so these run after them
  // and see the project path they set.
  connect(window_->action_project_open_, &QAction::triggered, this, [this]() {
    ReportExceptions([this]() {
      if (*window_->options_.project_path != options_project_path_) {
        LoadProjectOptions();
      }
    });
  });
  const auto save = [this]() {
    ReportExceptions([this]() {
      if (ExistsFile(*window_->options_.project_path)) SaveProjectOptions();
    });
  };
  connect(window_->action_project_save_, &QAction::triggered, this, save);
  connect(window_->action_project_save_as_, &QAction::triggered, this, save);
}

void GlobalReconstructionUi::LoadProjectOptions() {
  options_project_path_ = *window_->options_.project_path;
  options_ = glomap::GlobalMapperOptions();
  if (options_project_path_.empty()) return;
  const std::string path = OptionsFilePath(options_project_path_);
  if (ExistsFile(path) &&
      !glomap::ReadGlobalMapperOptionsFile(path, &options_)) {
    options_ = glomap::GlobalMapperOptions();
    ShowError("Cannot read " + path + "; using the default options.");
  }
}

void GlobalReconstructionUi::SaveProjectOptions() {
  options_project_path_ = *window_->options_.project_path;
  const std::string path = OptionsFilePath(options_project_path_);
  if (!glomap::WriteGlobalMapperOptionsFile(path, options_)) {
    ShowError("Cannot write " + path + ".");
  }
}

void GlobalReconstructionUi::ShowOptions() {
  options_dialog_->show();
  options_dialog_->raise();
  options_dialog_->activateWindow();
}

void GlobalReconstructionUi::ShowError(const std::string& message) {
  QMessageBox::critical(window_, tr("Global reconstruction"),
                        QString::fromStdString(message));
}

void GlobalReconstructionUi::ReportExceptions(
    const std::function<void()>& body) {
  try {
    body();
  } catch (...) {
    ShowError(glomap::StatusFromCurrentException().message());
  }
}

void GlobalReconstructionUi::Run() {
  if (IsRunning() || extracting_and_matching_) return;
  if (!window_->options_.Check()) {
    window_->ShowInvalidProjectError();
    return;
  }
  automatic_sparse_path_.clear();
  StartRun(*window_->options_.database_path, *window_->options_.image_path,
           /*ask_overwrite=*/true);
}

void GlobalReconstructionUi::StartRun(const std::string& database_path,
                                      const std::string& image_path,
                                      bool ask_overwrite) {
  // A missing or unreadable database is reported by the pipeline's database
  // reader, through the run's status, as on the command line.
  glomap::GlobalMapperOptions options = options_;
  options.image_path = image_path;
  if (const glomap::Status check = options.Check(); !check.ok()) {
    ShowError(check.message());
    return;
  }
  if (ask_overwrite) {
    // Asks before replacing existing models; stops the incremental mapper.
    if (!window_->ReconstructionOverwrite()) return;
  } else {
    // As the stock Automatic reconstruction: the window's models go.
    window_->reconstruction_manager_.Clear();
    window_->reconstruction_manager_widget_->Update();
    window_->RenderClear();
    window_->RenderNow();
  }

  if (controller_) controller_->Wait();
  controller_ = std::make_unique<glomap::GlobalMapperController>(
      options, database_path, &window_->reconstruction_manager_);
  glomap::GlobalMapperController* controller = controller_.get();
  controller->AddCallback(
      glomap::GlobalMapperController::STAGE_CALLBACK, [this]() {
        QMetaObject::invokeMethod(
            this,
            [this]() { ReportExceptions([this]() { UpdateProgress(); }); },
            Qt::QueuedConnection);
      });
  // The worker waits until the GUI has copied the model (as with
  // MainWindow's action_render_now_), so the viewer never sees it half
  // changed. Skipped once stopped: the GUI thread may be waiting for us.
  controller->AddCallback(
      glomap::GlobalMapperController::MODEL_UPDATED_CALLBACK,
      [this, controller]() {
        if (controller->IsStopped()) return;
        QMetaObject::invokeMethod(
            this,
            [this]() { ReportExceptions([this]() { OnModelUpdated(); }); },
            Qt::BlockingQueuedConnection);
      });
  controller->AddCallback(
      glomap::GlobalMapperController::FINISHED_CALLBACK, [this]() {
        QMetaObject::invokeMethod(
            this, [this]() { ReportExceptions([this]() { OnFinished(); }); },
            Qt::QueuedConnection);
      });

  running_ = true;
  paused_ = false;
  cancelling_ = false;
  closing_ = false;
  LockWindow();
  // The status bar's "Time", as for the incremental mapper; our progress
  // label shows the same clock.
  window_->timer_.Restart();
  progress_bar_->setValue(0);
  progress_label_->setToolTip(QString());
  progress_label_->show();
  progress_bar_->show();
  pause_button_->setText(tr("Pause"));
  pause_button_->setEnabled(true);
  pause_button_->show();
  cancel_button_->setEnabled(true);
  cancel_button_->show();
  UpdateProgress();
  progress_timer_->start(250);
  try {
    controller->Start();
  } catch (...) {
    // No thread could be started (the system's limits): undo the above, so
    // that the window is usable again, and say why.
    last_status_ = glomap::StatusFromCurrentException();
    running_ = false;
    controller_.reset();
    progress_timer_->stop();
    window_->timer_.Pause();
    window_->UpdateTimer();
    UnlockWindow();
    progress_label_->setText(tr("Global reconstruction failed"));
    progress_bar_->hide();
    pause_button_->hide();
    cancel_button_->hide();
    ShowError(last_status_.message());
  }
}

void GlobalReconstructionUi::InstallAutomaticMapperChoice() {
  AutomaticReconstructionWidget* widget =
      window_->automatic_reconstruction_widget_;
  QGridLayout* grid = widget->grid_layout_;
  QPushButton* run_button = nullptr;
  for (QPushButton* button : widget->findChildren<QPushButton*>()) {
    if (button->text() == tr("Run")) run_button = button;
  }
  if (grid == nullptr || run_button == nullptr) {
    LOG(WARNING) << "Automatic reconstruction has no Run button: its mapper "
                    "choice is not installed.";
    return;
  }
  // The Mapper row and the options button go above the Run button.
  grid->removeWidget(run_button);
  const int row = grid->rowCount();
  QLabel* label = new QLabel(tr("Mapper"), widget);
  label->setFont(widget->font());
  label->setAlignment(Qt::AlignRight | Qt::AlignVCenter);
  grid->addWidget(label, row, 0);
  automatic_mapper_cb_ = new QComboBox(widget);
  automatic_mapper_cb_->addItem(tr("Incremental"));
  automatic_mapper_cb_->addItem(tr("Global"));
  automatic_mapper_cb_->setToolTip(
      tr("Incremental: COLMAP's mapper. Global: the global mapper, with the "
         "options of Reconstruction > Global reconstruction options..."));
  grid->addWidget(automatic_mapper_cb_, row, 1);
  QPushButton* options_button =
      new QPushButton(tr("Global mapper options..."), widget);
  connect(options_button, &QPushButton::clicked, this,
          [this]() { ReportExceptions([this]() { ShowOptions(); }); });
  grid->addWidget(options_button, row + 1, 1);
  grid->addWidget(run_button, row + 2, 1);
  // The stock Run still runs the incremental choice.
  run_button->disconnect(widget);
  connect(run_button, &QPushButton::released, this, [this, widget]() {
    ReportExceptions([this, widget]() {
      if (automatic_mapper_cb_->currentIndex() == 1) {
        RunAutomatic();
      } else {
        widget->Run();
      }
    });
  });
}

void GlobalReconstructionUi::RunAutomatic() {
  if (IsRunning() || extracting_and_matching_) return;
  AutomaticReconstructionWidget* widget =
      window_->automatic_reconstruction_widget_;
  widget->WriteOptions();
  const AutomaticReconstructionController::Options& settings = widget->options_;
  // The stock widget's checks and messages.
  if (!ExistsDir(settings.workspace_path)) {
    QMessageBox::critical(widget, "", tr("Invalid workspace folder"));
    return;
  }
  if (!ExistsDir(settings.image_path)) {
    QMessageBox::critical(widget, "", tr("Invalid image folder"));
    return;
  }
  const char* const kDataTypes[] = {"individual", "video", "internet"};
  const char* const kQualities[] = {"low", "medium", "high", "extreme"};
  const std::string data_type =
      kDataTypes[std::clamp(widget->data_type_cb_->currentIndex(), 0, 2)];
  const std::string quality =
      kQualities[std::clamp(widget->quality_cb_->currentIndex(), 0, 3)];

  auto options = std::make_unique<OptionManager>();
  const std::string preset_error =
      ApplyGlobalPresets(data_type, quality, options.get());
  if (!preset_error.empty()) {
    ShowError(preset_error);
    return;
  }
  options->AddAllOptions();
  *options->database_path = JoinPaths(settings.workspace_path, "database.db");
  *options->image_path = settings.image_path;
  ImageReaderOptions& reader = *options->image_reader;
  reader.database_path = *options->database_path;
  reader.image_path = settings.image_path;
  if (!settings.mask_path.empty()) reader.mask_path = settings.mask_path;
  reader.single_camera = settings.single_camera;
  reader.camera_model = settings.camera_model;
  options->sift_extraction->num_threads = settings.num_threads;
  options->sift_matching->num_threads = settings.num_threads;
  options->sift_extraction->use_gpu = settings.use_gpu;
  options->sift_matching->use_gpu = settings.use_gpu;
  options->sift_extraction->gpu_index = settings.gpu_index;
  options->sift_matching->gpu_index = settings.gpu_index;
  automatic_options_ = std::move(options);
  automatic_sparse_path_ = JoinPaths(settings.workspace_path, "sparse");
  automatic_sparse_ = settings.sparse;
  automatic_dense_ = settings.dense;
  std::cout << "Automatic reconstruction with the global mapper: COLMAP "
               "3.8's extraction and matching into "
            << *automatic_options_->database_path
            << ", then the global mapper into " << automatic_sparse_path_ << "."
            << std::endl;

  auto thread = std::make_unique<ExtractionAndMatching>(
      *automatic_options_, data_type, settings.vocab_tree_path);
  ExtractionAndMatching* raw = thread.get();
  thread->AddCallback(Thread::FINISHED_CALLBACK, [this, raw]() {
    const std::string error = raw->Error();
    const bool stopped = raw->IsStopped();
    QMetaObject::invokeMethod(
        this,
        [this, error, stopped]() {
          ReportExceptions([this, &error, stopped]() {
            OnExtractionAndMatchingFinished(error, stopped);
          });
        },
        Qt::QueuedConnection);
  });
  extracting_and_matching_ = true;
  extraction_and_matching_thread_ = raw;
  widget->thread_control_widget_->StartThread(tr("Extracting and matching..."),
                                              true, std::move(thread));
}

void GlobalReconstructionUi::OnExtractionAndMatchingFinished(
    const std::string& error, bool stopped) {
  extracting_and_matching_ = false;
  extraction_and_matching_thread_ = nullptr;
  if (stopped || closing_) {
    automatic_sparse_path_.clear();
    return;
  }
  if (!error.empty()) {
    automatic_sparse_path_.clear();
    ShowError(error);
    return;
  }
  if (!automatic_sparse_) {
    automatic_sparse_path_.clear();
    return;
  }
  StartRun(*automatic_options_->database_path, *automatic_options_->image_path,
           /*ask_overwrite=*/false);
}

void GlobalReconstructionUi::Cancel() {
  if (!IsRunning() || cancelling_) return;
  cancelling_ = true;
  cancel_button_->setEnabled(false);
  pause_button_->setEnabled(false);
  // Stop() also wakes a paused worker, which then sees the stop at once.
  controller_->Stop();
  SetPaused(false);
  UpdateProgress();
}

void GlobalReconstructionUi::TogglePause() {
  if (!IsRunning() || cancelling_) return;
  SetPaused(!paused_);
}

void GlobalReconstructionUi::SetPaused(bool paused) {
  if (paused == paused_) return;
  paused_ = paused;
  // Like MainWindow's ReconstructionPause/Start: the clock stops with the
  // user's click, not when the worker reaches its next check. The models
  // stay locked: the worker still holds the working model.
  if (paused) {
    controller_->Pause();
    window_->timer_.Pause();
  } else {
    controller_->Resume();
    window_->timer_.Resume();
  }
  pause_button_->setText(paused ? tr("Resume") : tr("Pause"));
  UpdateProgress();
}

void GlobalReconstructionUi::StopAndWait() {
  if (!controller_) return;
  closing_ = true;
  cancelling_ = true;
  controller_->Stop();
  SetPaused(false);
  while (!controller_->IsFinished()) {
    QCoreApplication::processEvents(QEventLoop::ExcludeUserInputEvents, 20);
    QThread::msleep(5);
  }
  controller_->Wait();
}

void GlobalReconstructionUi::UpdateProgress() {
  if (!IsRunning()) return;
  const int stage_index = controller_->StageIndex();
  QString stage;
  if (cancelling_) {
    stage = tr("cancelling");
  } else if (stage_index < 0) {
    stage = tr("starting");
  } else {
    stage = QString("Stage %1/%2 %3")
                .arg(stage_index + 1)
                .arg(glomap::GlobalMapper::kNumStages)
                .arg(QString::fromStdString(controller_->StageName()));
  }
  if (paused_) {
    // colmap::Thread counts as running until the worker blocks in its
    // check: only then has the pipeline really stopped moving.
    stage += controller_->IsRunning() ? tr(", pausing") : tr(", paused");
  }
  progress_label_->setText(
      QString("Global reconstruction: %1 \u2014 %2")
          .arg(stage, FormatElapsed(window_->timer_.ElapsedSeconds())));
  // MainWindow redraws its "Time" only once a second, on a tick of its own:
  // a run that had reached its second second could still show "Time
  // 00:00:00:00" beside our "00:01". Redrawn here, the two always agree.
  window_->UpdateTimer();
  // The bar counts stages begun, like the "Stage k/n" text.
  progress_bar_->setValue(std::max(stage_index + 1, 0));
}

void GlobalReconstructionUi::OnModelUpdated() {
  // A cancelled run deletes its model: keep showing the last copy.
  if (cancelling_) return;
  window_->RenderNow();
  ++num_model_updates_shown_;
}

void GlobalReconstructionUi::OnFinished() {
  if (!running_) return;
  controller_->Wait();
  running_ = false;
  progress_timer_->stop();
  // A run can end while paused (after its last check): its clock is
  // already stopped, and pausing it again would lose the pause.
  if (!paused_) window_->timer_.Pause();
  paused_ = false;
  window_->UpdateTimer();
  last_status_ = controller_->RunStatus();
  UnlockWindow();

  // The working model is gone; show the largest final model (or nothing).
  ReconstructionManager& models = window_->reconstruction_manager_;
  window_->reconstruction_manager_widget_->Update();
  if (models.Size() > 0) {
    window_->reconstruction_manager_widget_->SelectReconstruction(0);
  }
  window_->RenderSelectedReconstruction();
  window_->action_bundle_adjustment_->setEnabled(models.Size() > 0);

  progress_bar_->hide();
  pause_button_->hide();
  cancel_button_->hide();
  const QString elapsed = FormatElapsed(window_->timer_.ElapsedSeconds());
  std::string error;
  if (last_status_.cancelled()) {
    progress_label_->setText(tr("Global reconstruction cancelled"));
  } else if (!last_status_.ok()) {
    error = last_status_.message();
  } else if (models.Size() == 0) {
    error = "Nothing was reconstructed.";
  } else {
    size_t num_images = 0;
    for (size_t i = 0; i < models.Size(); ++i) {
      num_images += models.Get(i).NumRegImages();
    }
    QString text =
        QString("Global reconstruction: %1 model(s), %2 images \u2014 %3")
            .arg(models.Size())
            .arg(num_images)
            .arg(elapsed);
    // What the user should know about the model (focal lengths the data
    // did not fix): named on the label, in full in its tooltip and the log.
    const std::vector<std::string>& warnings = controller_->Summary().warnings;
    QStringList details;
    for (const std::string& warning : warnings) {
      details << QString::fromStdString(warning);
    }
    if (!warnings.empty()) {
      text += QString(" \u2014 %1 warning(s), see the tooltip or the log")
                  .arg(warnings.size());
    }
    if (!automatic_sparse_path_.empty()) {
      // Automatic reconstruction: the models go to WORKSPACE/sparse, as the
      // command writes them (atomically: a failure keeps the old ones).
      error = WriteModels(models, controller_->GetGeoregistration(),
                          automatic_sparse_path_, *automatic_options_);
      text += QString(" \u2014 written to %1")
                  .arg(QString::fromStdString(automatic_sparse_path_));
      if (automatic_dense_) {
        std::cout << "WARNING: Skipping dense reconstruction: patch-match "
                     "stereo needs CUDA, which this COLMAP was built "
                     "without; the sparse models stay in "
                  << automatic_sparse_path_ << "." << std::endl;
      }
    }
    progress_label_->setText(text);
    progress_label_->setToolTip(details.join("\n\n"));
  }
  if (!error.empty()) {
    progress_label_->setText(tr("Global reconstruction failed"));
    if (!closing_) ShowError(error);
  }
}

void GlobalReconstructionUi::LockWindow() {
  // MainWindow's blocking actions (which include ours) plus the ones that
  // would reset, replace or read the models while the worker changes them.
  std::vector<QAction*> actions = window_->blocking_actions_;
  for (QAction* action :
       {window_->action_project_new_, window_->action_project_open_,
        window_->action_automatic_reconstruction_,
        window_->action_reconstruction_reset_,
        window_->action_dense_reconstruction_,
        window_->action_reconstruction_stats_,
        window_->action_extract_colors_}) {
    actions.push_back(action);
  }
  locked_actions_.clear();
  for (QAction* action : actions) {
    locked_actions_.emplace_back(action, action->isEnabled());
    action->setEnabled(false);
  }
  // Choosing another model would render it from the GUI thread.
  window_->reconstruction_manager_widget_->setEnabled(false);
}

void GlobalReconstructionUi::UnlockWindow() {
  for (const auto& [action, enabled] : locked_actions_) {
    action->setEnabled(enabled);
  }
  locked_actions_.clear();
  window_->reconstruction_manager_widget_->setEnabled(true);
}

bool GlobalReconstructionUi::eventFilter(QObject* watched, QEvent* event) {
  if (watched == window_ && event->type() == QEvent::Close &&
      extracting_and_matching_) {
    // The window asks first; if it closes, extraction or matching stops
    // (its thread must end before the widget that owns it goes).
    static_cast<QObject*>(window_)->event(event);
    if (event->isAccepted()) {
      closing_ = true;
      extraction_and_matching_thread_->Stop();
      while (extracting_and_matching_) {
        QCoreApplication::processEvents(QEventLoop::ExcludeUserInputEvents, 20);
        QThread::msleep(5);
      }
      // The thread control's own clean-up (join, reset) is queued too.
      QCoreApplication::processEvents(QEventLoop::ExcludeUserInputEvents, 50);
    }
    return true;
  }
  if (watched == window_ && event->type() == QEvent::Close && IsRunning()) {
    // The window asks its questions first; stop only if it really closes.
    static_cast<QObject*>(window_)->event(event);
    if (event->isAccepted()) StopAndWait();
    return true;
  }
  return QObject::eventFilter(watched, event);
}

}  // namespace colmap
