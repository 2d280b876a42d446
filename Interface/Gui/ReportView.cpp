#include "ReportView.h"

#include <QHeaderView>
#include <QLabel>
#include <QPainter>
#include <QRegularExpression>
#include <QSplitter>
#include <QTableWidget>
#include <QVBoxLayout>

#include <algorithm>
#include <cmath>

#include "GuiStyle.h"

namespace tetflow::gui {

bool parseHistogram(const QString& text, QStringList& labels, QVector<double>& counts) {
  labels.clear();
  counts.clear();
  for (const QString& tok : text.split(QRegularExpression("\\s+"), Qt::SkipEmptyParts)) {
    const int colon = tok.lastIndexOf(':');
    if (colon <= 0) return false;
    bool ok = false;
    const double c = tok.mid(colon + 1).toDouble(&ok);
    if (!ok) return false;
    labels << tok.left(colon);
    counts << c;
  }
  return !counts.isEmpty();
}

QVector<double> parseSeries(const QString& text) {
  QVector<double> v;
  for (QString tok : text.split(QRegularExpression("[\\s,;]+"), Qt::SkipEmptyParts)) {
    if (const int colon = tok.lastIndexOf(':'); colon >= 0) tok = tok.mid(colon + 1);
    bool ok = false;
    const double x = tok.toDouble(&ok);
    if (!ok) return {};
    v << x;
  }
  return v;
}

PlotWidget::PlotWidget(QWidget* parent) : QWidget(parent) { setMinimumHeight(160); }

void PlotWidget::clear() {
  mode_ = Mode::None;
  values_.clear();
  labels_.clear();
  update();
}

void PlotWidget::setHistogram(const QString& title, const QStringList& labels, const QVector<double>& counts) {
  mode_ = Mode::Histogram;
  title_ = title;
  labels_ = labels;
  values_ = counts;
  update();
}

void PlotWidget::setLogSeries(const QString& title, const QVector<double>& values) {
  mode_ = Mode::LogSeries;
  title_ = title;
  values_ = values;
  labels_.clear();
  update();
}

void PlotWidget::paintEvent(QPaintEvent*) {
  QPainter p(this);
  p.setRenderHint(QPainter::Antialiasing);
  p.fillRect(rect(), QColor(250, 250, 252));
  p.setPen(Qt::darkGray);
  if (mode_ == Mode::None || values_.isEmpty()) {
    p.drawText(rect(), Qt::AlignCenter, tr("no plot for this report"));
    return;
  }
  const QFontMetrics fm(font());
  const QRectF area(56, 24, width() - 70, height() - 24 - 2.2 * fm.height());
  p.setPen(Qt::black);
  p.drawText(QRectF(0, 2, width(), 20), Qt::AlignCenter, title_);
  p.setPen(QColor(120, 120, 120));
  p.drawLine(area.bottomLeft(), area.bottomRight());
  p.drawLine(area.bottomLeft(), area.topLeft());

  if (mode_ == Mode::Histogram) {
    const double maxC = std::max(1.0, *std::max_element(values_.begin(), values_.end()));
    const int n = values_.size();
    const double bw = area.width() / n;
    for (int i = 0; i < n; ++i) {
      const double h = area.height() * values_[i] / maxC;
      const QRectF bar(area.left() + i * bw + 1, area.bottom() - h, std::max(1.0, bw - 2), h);
      const bool low = labels_.value(i).section('-', 0, 0).toDouble() < 10.0; // < 10 deg in red
      const QColor col = low ? QColor(220, 90, 80) : QColor(70, 130, 200);
      p.fillRect(bar, col);
      if (values_[i] > 0 && h < 2) p.fillRect(QRectF(bar.left(), area.bottom() - 2, bar.width(), 2), col); // non-empty bins stay visible
    }
    p.setPen(Qt::black);
    const int every = std::max(1, int(std::ceil(n / (area.width() / (fm.horizontalAdvance("180") + 8)))));
    for (int i = 0; i <= n; i += every) {
      QString lab = i < labels_.size() ? labels_[i].section('-', 0, 0) : labels_.value(n - 1).section('-', 1, 1);
      p.drawText(QRectF(area.left() + i * bw - 20, area.bottom() + 2, 40, fm.height()), Qt::AlignHCenter, lab);
    }
    p.drawText(QRectF(area.left(), area.bottom() + fm.height(), area.width(), fm.height()), Qt::AlignCenter,
               tr("per-tet minimum dihedral angle (deg)"));
    p.drawText(QRectF(0, area.top() - 4, 52, fm.height()), Qt::AlignRight, QString::number(maxC, 'g', 6));
    p.drawText(QRectF(0, area.bottom() - fm.height(), 52, fm.height()), Qt::AlignRight, "0");
    return;
  }
  // LogSeries: y on log10 scale.
  double lo = 1e300, hi = -1e300;
  for (double v : values_)
    if (v > 0) {
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
  if (lo > hi) {
    p.drawText(area, Qt::AlignCenter, tr("no positive values"));
    return;
  }
  double l0 = std::floor(std::log10(lo)), l1 = std::ceil(std::log10(hi));
  if (l1 <= l0) l1 = l0 + 1;
  auto mapY = [&](double v) { return area.bottom() - (std::log10(v) - l0) / (l1 - l0) * area.height(); };
  const int n = values_.size();
  auto mapX = [&](int i) { return area.left() + (n > 1 ? double(i) / (n - 1) : 0.5) * area.width(); };
  p.setPen(QColor(225, 225, 225));
  for (double e = l0; e <= l1; e += 1) {
    const double y = mapY(std::pow(10.0, e));
    p.drawLine(QPointF(area.left(), y), QPointF(area.right(), y));
    p.setPen(Qt::black);
    p.drawText(QRectF(0, y - fm.height() / 2.0, 52, fm.height()), Qt::AlignRight, QString("1e%1").arg(int(e)));
    p.setPen(QColor(225, 225, 225));
  }
  QPainterPath path;
  bool started = false;
  for (int i = 0; i < n; ++i) {
    if (values_[i] <= 0) continue;
    const QPointF pt(mapX(i), mapY(values_[i]));
    if (!started) path.moveTo(pt);
    else path.lineTo(pt);
    started = true;
  }
  p.setPen(QPen(QColor(200, 60, 60), 2));
  p.drawPath(path);
  p.setPen(Qt::black);
  p.drawText(QRectF(area.left(), area.bottom() + fm.height(), area.width(), fm.height()), Qt::AlignCenter,
             tr("iteration (%1)").arg(n - 1));
}

ReportView::ReportView(QWidget* parent) : QWidget(parent) {
  auto* lay = new QVBoxLayout(this);
  lay->setContentsMargins(2, 2, 2, 2);
  title_ = new QLabel(tr("Select a module to see its report"));
  title_->setWordWrap(true); // a long error message wraps instead of widening the window
  auto* split = new QSplitter(Qt::Horizontal);
  table_ = new QTableWidget(0, 2);
  table_->setHorizontalHeaderLabels({tr("key"), tr("value")});
  table_->horizontalHeader()->setStretchLastSection(true);
  table_->verticalHeader()->setVisible(false);
  table_->setEditTriggers(QAbstractItemView::NoEditTriggers);
  plot_ = new PlotWidget;
  split->addWidget(table_);
  split->addWidget(plot_);
  split->setStretchFactor(0, 1);
  split->setStretchFactor(1, 1);
  lay->addWidget(title_);
  lay->addWidget(split, 1);
}

void ReportView::showMessage(const QString& text) {
  title_->setText(text);
  table_->setRowCount(0);
  plot_->clear();
}

void ReportView::showReport(const QString& title, const Report& report) {
  title_->setText(title);
  table_->setRowCount(int(report.entries().size()));
  int row = 0;
  plot_->clear();
  bool plotted = false;
  for (const auto& [key, value] : report.entries()) {
    table_->setItem(row, 0, new QTableWidgetItem(qs(key)));
    table_->setItem(row, 1, new QTableWidgetItem(qs(formatReportValue(value))));
    ++row;
    const auto* text = std::get_if<std::string>(&value);
    if (!text || plotted) continue;
    if (key == "min_dihedral_histogram") {
      QStringList labels;
      QVector<double> counts;
      if (parseHistogram(qs(*text), labels, counts)) {
        plot_->setHistogram(tr("Histogram of per-tet minimum dihedral angles"), labels, counts);
        plotted = true;
      }
    } else if (key.find("residual_history") != std::string::npos) {
      const QVector<double> v = parseSeries(qs(*text));
      if (!v.isEmpty()) {
        plot_->setLogSeries(tr("Relative residual per iteration (log scale)"), v);
        plotted = true;
      }
    }
  }
  table_->resizeColumnToContents(0);
}

} // namespace tetflow::gui
