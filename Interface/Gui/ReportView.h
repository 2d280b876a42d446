#pragma once
// Report view: the selected module's Report as a key/value table, plus a plot when the report
// has one: EvaluateQuality's "min_dihedral_histogram" ("0-5:0 5-10:3 ...") as a bar chart, and a
// solver residual history (any key containing "residual_history": numbers, or "k:value" items,
// separated by spaces, commas or semicolons) on a log scale.
#include <QWidget>

#include "Algorithms/Core/Report.h"

class QTableWidget;
class QLabel;

namespace tetflow::gui {

class PlotWidget : public QWidget {
  Q_OBJECT
public:
  enum class Mode { None, Histogram, LogSeries };
  explicit PlotWidget(QWidget* parent = nullptr);
  void clear();
  void setHistogram(const QString& title, const QStringList& labels, const QVector<double>& counts);
  void setLogSeries(const QString& title, const QVector<double>& values);
  Mode mode() const { return mode_; }
  const QVector<double>& values() const { return values_; }
  QSize sizeHint() const override { return {420, 220}; }

protected:
  void paintEvent(QPaintEvent*) override;

private:
  Mode mode_ = Mode::None;
  QString title_;
  QStringList labels_;
  QVector<double> values_;
};

// Parsers (public for tests).
bool parseHistogram(const QString& text, QStringList& labels, QVector<double>& counts);
QVector<double> parseSeries(const QString& text);

class ReportView : public QWidget {
  Q_OBJECT
public:
  explicit ReportView(QWidget* parent = nullptr);
  void showReport(const QString& title, const Report& report);
  void showMessage(const QString& text);
  QTableWidget* table() const { return table_; }
  PlotWidget* plot() const { return plot_; }

private:
  QLabel* title_;
  QTableWidget* table_;
  PlotWidget* plot_;
};

} // namespace tetflow::gui
