import { act, render, screen, within } from '@testing-library/react';
import { beforeEach, describe, expect, it } from 'vitest';
import { useMissionStore } from '@/stores/missionStore';
import { fiveStates } from '@/testing/fixtures';
import { MissionPanel } from './MissionPanel';

describe('MissionPanel', () => {
  beforeEach(() => useMissionStore.getState().clear());

  it('renders every step of a snapshot with its own status treatment', () => {
    useMissionStore.getState().started({ mission_id: 'm-abc123', instruction: 'Fetch the package', started_at: 1_700_000_000 });
    useMissionStore.getState().applySnapshot(fiveStates);
    render(<MissionPanel />);

    const panel = screen.getByRole('region', { name: 'Mission' });
    const items = within(panel).getAllByRole('listitem');
    expect(items.map((li) => [li.dataset.stepId, li.dataset.status])).toEqual([
      ['s1', 'failed'],
      ['s1b', 'succeeded'],
      ['s1c', 'running'],
      ['s2', 'pending'],
      ['s9', 'skipped'],
    ]);
    const failed = items[0]!;
    expect(failed).toHaveTextContent('DOOR_CLOSED');
    expect(failed.querySelector('.text-status-failed')).not.toBeNull();
    expect(items[1]!.querySelector('.text-status-succeeded')).toHaveTextContent('✓');
    expect(items[2]).toHaveClass('shimmer');
    expect(items[2]).toHaveTextContent('ETA 12 s · 40 %');
    expect(items[3]!.querySelector('.text-status-pending')).toHaveTextContent('○');
    expect(within(items[4]!).getByText('Ask at reception')).toHaveClass('line-through');
    expect(within(panel).getByText('Fetch the package')).toBeInTheDocument();
    expect(within(panel).getByText('running', { selector: '[data-mission-state]' })).toBeInTheDocument();
    expect(within(panel).getByRole('button', { name: 'Stop mission' })).toBeInTheDocument();
  });

  it('shows the paused banner with Continue and Abort', () => {
    useMissionStore.getState().applySnapshot({ ...fiveStates, state: 'paused' });
    render(<MissionPanel />);
    expect(screen.getByRole('alert')).toHaveTextContent('Paused — continue or abort?');
    expect(screen.getByRole('button', { name: 'Continue' })).toBeInTheDocument();
    expect(screen.getByRole('button', { name: 'Abort' })).toBeInTheDocument();
  });

  it('animates steps that a replan added and collapses once the mission ends', () => {
    useMissionStore.getState().applySnapshot({ ...fiveStates, steps: fiveStates.steps!.slice(0, 1) });
    render(<MissionPanel />);
    act(() => useMissionStore.getState().applySnapshot(fiveStates));
    const added = screen.getAllByRole('listitem').find((li) => li.dataset.stepId === 's1b');
    expect(added).toHaveClass('animate-step-in');
    act(() => useMissionStore.getState().finished({ mission_id: 'm-abc123', outcome: 'succeeded', summary: 'done' }));
    expect(screen.queryByRole('listitem')).toBeNull();
    expect(screen.getByRole('region', { name: 'Mission' })).toHaveTextContent('No mission running');
  });

  it('keeps the activity log collapsible', async () => {
    useMissionStore.getState().applySnapshot(fiveStates);
    useMissionStore.getState().addEvent({ mission_id: 'm-abc123', kind: 'say', text: 'On my way', ts: 1_700_000_001 });
    render(<MissionPanel />);
    const activity = screen.getByRole('region', { name: 'Activity' });
    expect(activity).toHaveTextContent('On my way');
    act(() => within(activity).getByRole('button').click());
    expect(activity).not.toHaveTextContent('On my way');
  });
});
