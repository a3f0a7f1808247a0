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

  it('says which window is empty when nothing was seen in it', async () => {
    answer(200, history([]));
    render(<HistoryPanel />);
    expect(await screen.findByText('Nothing seen in the last 24 hours.')).toBeInTheDocument();
  });

  it('offers the windows the memory holds as a labelled choice, the last 24 hours first', async () => {
    answer(200, history([]));
    render(<HistoryPanel />);
    const choice = within(screen.getByRole('region', { name: 'History' })).getByRole('combobox', {
      name: 'History window',
    });
    expect(choice).toHaveDisplayValue('Last 24 hours');
    expect(within(choice).getAllByRole('option').map((o) => o.textContent)).toEqual([
      'Last hour',
      'Today',
      'Last 24 hours',
      'Last 7 days',
    ]);
    await screen.findByText('Nothing seen in the last 24 hours.');
  });

  it('fetches a new window at once with its since, names it when empty, and keeps polling it', async () => {
    vi.useFakeTimers({ shouldAdvanceTime: true });
    const fetchMock = answer(200, history([]));
    render(<HistoryPanel />);
    await screen.findByText('Nothing seen in the last 24 hours.');
    expect(fetchMock).toHaveBeenCalledTimes(1);
    const choice = screen.getByRole('combobox', { name: 'History window' });

    await userEvent.selectOptions(choice, 'Last hour');
    expect(await screen.findByText('Nothing seen in the last hour.')).toBeInTheDocument();
    expect(fetchMock).toHaveBeenCalledTimes(2); // at once, not at the next 5 s tick
    expect(fetchMock).toHaveBeenLastCalledWith('/api/history?since=-1h&limit=50', expect.anything());

    await userEvent.selectOptions(choice, 'Today');
    expect(await screen.findByText('Nothing seen today.')).toBeInTheDocument();
    // midnight in the site's time zone, resolved by the memory server
    expect(fetchMock).toHaveBeenLastCalledWith('/api/history?since=00%3A00&limit=50', expect.anything());

    await userEvent.selectOptions(choice, 'Last 7 days');
    expect(await screen.findByText('Nothing seen in the last 7 days.')).toBeInTheDocument();
    expect(fetchMock).toHaveBeenLastCalledWith('/api/history?since=-7d&limit=50', expect.anything());
    const calls = fetchMock.mock.calls.length;
    await act(async () => {
      await vi.advanceTimersByTimeAsync(5000);
    });
    expect(fetchMock).toHaveBeenCalledTimes(calls + 1);
    expect(fetchMock).toHaveBeenLastCalledWith('/api/history?since=-7d&limit=50', expect.anything());
  });

  it('drops a late answer for the window the operator has left', async () => {
    let answerOld: (r: Response) => void = () => undefined;
    const fetchMock = vi.fn((url: string) =>
      url.includes('since=-24h')
        ? new Promise<Response>((resolve) => {
            answerOld = resolve;
          })
        : Promise.resolve(new Response(JSON.stringify(history([])), { status: 200 })),
    );
    vi.stubGlobal('fetch', fetchMock);
    render(<HistoryPanel />);
    await waitFor(() => expect(fetchMock).toHaveBeenCalledTimes(1));
    await userEvent.selectOptions(screen.getByRole('combobox', { name: 'History window' }), 'Last hour');
    await screen.findByText('Nothing seen in the last hour.');
    await act(async () => {
      answerOld(new Response(JSON.stringify(history([parcel])), { status: 200 }));
      await Promise.resolve();
    });
    expect(screen.getByText('Nothing seen in the last hour.')).toBeInTheDocument();
    expect(screen.queryByRole('button', { name: /yellow package/ })).toBeNull();
  });

  it('says when the window holds more than the panel lists', async () => {
    answer(200, { ...history([parcel, mug]), truncated: true });
    render(<HistoryPanel />);
    expect(await screen.findByText('Showing the newest 50 sightings in the last 24 hours.')).toBeInTheDocument();
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
    await screen.findByText('Nothing seen in the last 24 hours.');
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
