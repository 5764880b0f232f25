"""Widgets sized so their labels show, and the record of where each one went.

ImGui draws a widget's label to the right of its frame; with the default item width (65% of the
window) a label longer than the remaining 35% is cut at the panel's edge ("light intensi").
:meth:`Layout.fit` sizes the next widget to the row left after its label, measured with
``imgui.calc_text_size``; when that leaves less than :data:`MIN_WIDGET` pixels the label goes on
its own line above a full-width widget. Within a section the labels share one column, as wide as
the section's widest label last frame (where that leaves the widget its minimum), so the widgets
end, and the labels start, at one x. Text is wrapped at the panel's edge (the panel pushes a
wrap position) and buttons go on the next line when they would not fit beside the previous one.

Every tracked widget lands in ``rects`` (label -> screen rectangle, for tests that click the real
widgets) and in ``items`` (:class:`Item`: the label as shown, its text width and the rectangle),
with ``right``, the panel's content edge this frame, and ``edge``, its visible edge (less the
scroll bar; section headers reach past ``right`` to it): a test checks that no item passes them.
"""
from __future__ import annotations

import re

from dataclasses import dataclass

MIN_WIDGET = 80.0  # pixels: narrower than this, a widget's label goes on its own line


@dataclass(frozen=True)
class Item:
    """One widget as laid out this frame (screen pixels)."""

    label: str  # the text shown (what precedes "##"), "" when hidden
    text_width: float  # calc_text_size(label).x
    rect: tuple[float, float, float, float]  # x0, y0, x1, y1 of the item, label included
    kind: str  # "widget", "label" (a label on its own line), "button", "header"


def shown_label(label: str) -> str:
    """The part of an ImGui label that is drawn (the text before ``##``)."""
    return label.split("##", 1)[0]


class Layout:
    """Label fitting and the per-frame record; mixed into :class:`~.ViewerUI`."""

    def _begin_layout(self) -> None:
        """At the top of the panel: forget last frame's items, note the content edge."""
        imgui = self.imgui
        self.items: list[Item] = []
        self._fitted: dict[str, str] = {}  # label -> what fit() returned for it
        self._columns, self._widest = self._widest, {}  # section -> its widest label
        self.right = imgui.get_cursor_screen_pos().x + imgui.get_content_region_avail().x
        scrollbar = imgui.get_style().scrollbar_size if imgui.get_scroll_max_y() > 0 else 0.0
        self.edge = imgui.get_window_pos().x + imgui.get_window_width() - scrollbar

    def section(self, name: str) -> None:
        """The widgets that follow belong to section ``name`` (they share a label column)."""
        self._section = name

    def _record(self, label: str, kind: str = "widget", key: str | None = None) -> None:
        """The last item's rectangle under ``key`` (default ``label``); ``label`` is what the
        widget was given (a label moved to its own line by :meth:`fit` is hidden: "##...")."""
        imgui = self.imgui
        a, b = imgui.get_item_rect_min(), imgui.get_item_rect_max()
        rect = (a.x, a.y, b.x, b.y)
        self.rects[key or label] = rect
        text = shown_label(label)
        self.items.append(Item(text, imgui.calc_text_size(text).x if text else 0.0, rect, kind))

    def _track(self, label: str) -> None:
        """Record the widget just drawn for ``label`` (after :meth:`fit`, as it was shown)."""
        shown = self._fitted.get(label, label)
        self._record(shown, key=label)

    def fit(self, label: str) -> str:
        """Size the next widget so that ``label`` shows in the row; returns the label to pass to
        the widget (the same, or hidden when the label went on its own line above it)."""
        imgui = self.imgui
        avail = imgui.get_content_region_avail().x
        text = shown_label(label)
        self._fitted.pop(label, None)
        if not text:
            imgui.set_next_item_width(avail)
            return label
        width = imgui.calc_text_size(text).x
        self._widest[self._section] = max(self._widest.get(self._section, 0.0), width)
        spacing = imgui.get_style().item_inner_spacing.x
        column = max(width, self._columns.get(self._section, 0.0))
        room = avail - column - spacing
        if room < MIN_WIDGET:  # the shared column leaves too little: this label's own width
            room = avail - width - spacing
        if room >= MIN_WIDGET:
            imgui.set_next_item_width(room)
            return label
        imgui.text(text)
        self._record(text, "label", key=f"{label} (label)")
        imgui.set_next_item_width(avail)
        self._fitted[label] = "##" + label
        return "##" + label

    def _wrap(self, text: str, width: float) -> str:
        """``text`` broken into lines at spaces, and after the underscores of a [render] key,
        so that each fits ``width`` pixels."""
        lines: list[str] = []
        for piece in re.findall(r"[^ _]*_|[^ _]+", text):
            if lines:
                line = lines[-1] + ("" if lines[-1].endswith("_") else " ") + piece
                if self.imgui.calc_text_size(line).x <= width:
                    lines[-1] = line
                    continue
            lines.append(piece)
        return "\n".join(lines)

    def button(self, label: str, same_line: bool = False) -> bool:
        """A button; beside the previous item when ``same_line`` and it fits there; its text
        on several lines when one is wider than the panel."""
        imgui = self.imgui
        style = imgui.get_style()
        text, _, key = label.partition("##")
        width = imgui.calc_text_size(text).x + 2 * style.frame_padding.x
        if same_line and imgui.get_item_rect_max().x + style.item_spacing.x + width <= self.right:
            imgui.same_line()
        avail = imgui.get_content_region_avail().x
        if width > avail:
            text = self._wrap(text, avail - 2 * style.frame_padding.x)
        pressed = imgui.button(f"{text}###{label}")  # the id stays when the text wraps
        self._record(text, "button", key=label)
        return pressed

    def _combo(self, label: str, current: str, items) -> str:
        items = list(items)
        index = items.index(current) if current in items else 0
        changed, index = self.imgui.combo(self.fit(label), index, items)
        self._track(label)
        return items[index] if changed else current

    def _slider(self, label: str, value: float, lo: float, hi: float, fmt: str = "%.3f") -> float:
        _, value = self.imgui.slider_float(self.fit(label), float(value), lo, hi, fmt)
        self._track(label)
        return value

    def _checkbox(self, label: str, value: bool) -> tuple[bool, bool]:
        """A checkbox; its label wrapped beside it when one line would pass the panel's edge."""
        imgui = self.imgui
        text = shown_label(label)
        box = imgui.get_frame_height() + imgui.get_style().item_inner_spacing.x
        if box + imgui.calc_text_size(text).x <= imgui.get_content_region_avail().x:
            toggled, value = imgui.checkbox(label, value)
            self._record(label)
            return toggled, value
        toggled, value = imgui.checkbox("##" + label, value)
        self._record("##" + label, key=label)
        self._text_beside(text)
        return toggled, value

    def _tree_node(self, text: str, key: str) -> bool:
        """A tree node labelled ``text`` (id ``key``), its label wrapped beside the arrow when one
        line would pass the panel's edge."""
        imgui = self.imgui
        if self.open_all:
            imgui.set_next_item_open(True)
        arrow = imgui.get_tree_node_to_label_spacing()
        if arrow + imgui.calc_text_size(text).x <= imgui.get_content_region_avail().x:
            opened = imgui.tree_node(f"{text}##{key}")
            self._record(text, "header", key=key)
            return opened
        opened = imgui.tree_node_ex(f"##{key}", imgui.TreeNodeFlags_.span_avail_width)
        self._record("", "header", key=key)
        self._text_beside(text)
        return opened

    def _text_beside(self, text: str) -> None:
        """``text`` after the last item on its line, wrapped at the panel's edge."""
        imgui = self.imgui
        imgui.same_line(0.0, imgui.get_style().item_inner_spacing.x)
        lines = self._wrap(text, imgui.get_content_region_avail().x)
        imgui.text(lines)
        self._record(lines, "label", key=f"{text} (label)")
