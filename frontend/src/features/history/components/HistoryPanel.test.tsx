import { act, render, screen, waitFor, within } from '@testing-library/react';
import userEvent from '@testing-library/user-event';
import { afterEach, describe, expect, it, vi } from 'vitest';
import { useHistoryStore } from '@/stores/historyStore';
import { localClock, type History, type Sighting } from '../api/history';
import { HistoryPanel } from './HistoryPanel';

const parcel: Sighting = {
  id: 's-2',
  label: 'yellow package',
  skill: 'find_object',
  first_seen: '2026-11-24T14:03:12.000Z',
  last_seen: '2026-11-24T14:03:20.000Z',
  ago: '2 min ago',
  t: 1_795_615_392,
  seen_for: '8 s',
  place: 'mailroom',
  pose: { x: 9, y: -3, yaw: 0.5, map: 'office' },
  score: 0.91,
  count: 12,
};
const mug: Sighting = { ...parcel, id: 's-1', label: 'red mug', first_seen: '2026-11-24T13:40:00.000Z', ago: '25 min ago', place: null, pose: null };

function answer(status: number, body: unknown) {
  const fetchMock = vi.fn(async () => new Response(JSON.stringify(body), { status }));
  vi.stubGlobal('fetch', fetchMock);
  return fetchMock;
}

const history = (sightings: Sighting[]): History => ({ since: null, now: null, count: sightings.length, truncated: false, sightings });

afterEach(() => {
  vi.unstubAllGlobals();
  vi.useRealTimers();
  useHistoryStore.setState({ selected: null });
});

describe('History panel', () => {
  it('lists recent sightings newest first with local time, "ago", place and label', async () => {
    const fetchMock = answer(200, history([parcel, mug]));
    render(<HistoryPanel />);
    const panel = screen.getByRole('region', { name: 'History' });
    const rows = await within(panel).findAllByRole('listitem');
    expect(rows.map((r) => r.dataset.sightingId)).toEqual(['s-2', 's-1']);
    expect(rows[0]).toHaveTextContent('yellow package');
    expect(rows[0]).toHaveTextContent('mailroom');
    expect(rows[0]).toHaveTextContent(localClock(parcel.first_seen));
    expect(rows[0]).toHaveTextContent('2 min ago');
    expect(rows[1]).toHaveTextContent('no named place');
    expect(fetchMock).toHaveBeenCalledWith('/api/history?since=-24h&limit=50', expect.anything());
  });

  it('says nothing has been recorded yet when the memory is empty', async () => {
    answer(200, history([]));
    render(<HistoryPanel />);
    expect(await screen.findByText('Nothing has been recorded yet.')).toBeInTheDocument();
  });

  it('says the memory server is not connected on a 503', async () => {
    answer(503, { error: 'episodic_unavailable', detail: 'The episodic memory server is not connected.' });
    render(<HistoryPanel />);
    const panel = screen.getByRole('region', { name: 'History' });
    await waitFor(() => expect(panel).toHaveTextContent('episodic memory server is not connected'));
    expect(within(panel).queryByRole('list')).toBeNull();
  });

  it('asks an absent memory server again every 30 s, not every 5 s', async () => {
    vi.useFakeTimers({ shouldAdvanceTime: true });
    const fetchMock = answer(503, { error: 'episodic_unavailable', detail: 'not connected' });
    render(<HistoryPanel />);
    await screen.findByText(/Memory unavailable/);
    const calls = fetchMock.mock.calls.length;
    await act(async () => {
      await vi.advanceTimersByTimeAsync(6000);
    });
    expect(fetchMock.mock.calls.length).toBeLessThanOrEqual(calls + 1); // the switch to 30 s may ask once
    const settled = fetchMock.mock.calls.length;
    await act(async () => {
      await vi.advanceTimersByTimeAsync(20_000);
    });
    expect(fetchMock.mock.calls.length).toBe(settled);
    await act(async () => {
      await vi.advanceTimersByTimeAsync(11_000);
    });
    expect(fetchMock.mock.calls.length).toBe(settled + 1);
  });

  it('shows a memory server error with its message', async () => {
    answer(502, { error: 'episodic_error', detail: 'what_happened: database is locked' });
    render(<HistoryPanel />);
    expect(await screen.findByText('History unavailable: what_happened: database is locked')).toBeInTheDocument();
  });

  it('chooses a sighting by keyboard, and choosing it again clears it', async () => {
    answer(200, history([parcel, mug]));
    render(<HistoryPanel />);
    const row = await screen.findByRole('button', { name: /yellow package/ });
    expect(row).toHaveAttribute('aria-pressed', 'false');
    row.focus();
    await userEvent.keyboard('{Enter}');
    expect(useHistoryStore.getState().selected?.id).toBe('s-2');
    expect(row).toHaveAttribute('aria-pressed', 'true');
    expect(screen.getByText('Map: where the robot was when it saw yellow package.')).toBeInTheDocument();
    await userEvent.keyboard(' ');
    expect(useHistoryStore.getState().selected).toBeNull();
  });

  it('says so when a chosen sighting has no recorded position', async () => {
    answer(200, history([parcel, mug]));
    render(<HistoryPanel />);
    await userEvent.click(await screen.findByRole('button', { name: /red mug/ }));
    expect(screen.getByText('No robot position was recorded for red mug.')).toBeInTheDocument();
  });

  it('refreshes on demand and by polling', async () => {
    vi.useFakeTimers({ shouldAdvanceTime: true });
    const fetchMock = answer(200, history([]));
    render(<HistoryPanel />);
    await screen.findByText('Nothing has been recorded yet.');
    expect(fetchMock).toHaveBeenCalledTimes(1);
    fetchMock.mockImplementation(async () => new Response(JSON.stringify(history([parcel])), { status: 200 }));
    await act(async () => {
      await vi.advanceTimersByTimeAsync(5000);
    });
    expect(await screen.findByRole('button', { name: /yellow package/ })).toBeInTheDocument();
    expect(fetchMock).toHaveBeenCalledTimes(2);
    await userEvent.click(screen.getByRole('button', { name: 'Refresh' }));
    await waitFor(() => expect(fetchMock).toHaveBeenCalledTimes(3));
  });
});
